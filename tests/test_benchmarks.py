"""The scripts of benchmarks/ against today's code: every module imports and its command
line answers ``--help``; the few whose smallest run takes about a second run at that size.
Their figures are not checked here (no timing in tests): only that they still run.
"""

import contextlib
import importlib
import io
import os
import pathlib
import sys

import pytest

BENCHMARKS = pathlib.Path(__file__).resolve().parents[1] / "benchmarks"
MODULES = sorted(path.stem for path in BENCHMARKS.glob("*.py"))
# packages of the peers' environment (docs/performance.md, "Re-solves against rockit"),
# not dependencies of dmoc: a module that needs one at import is skipped without it
PEERS = ("rockit", "pydrake")
# the smallest runs that take about a second on a warm compile cache, as smoke-run in
# docs/performance.md, "The benchmarks smoke-run"
QUICK = {
    "first_solve": ["--repeat", "1"],
    "build_split": ["--repeat", "1", "--steps", "50"],
    "lockstep": ["--runs", "10", "--steps", "100", "--repeat", "1"],
    "verdict": ["--repeat", "1", "--steps", "100", "--rules", "midpoint"],
}


@pytest.fixture(autouse=True)
def benchmarks_path(monkeypatch):
    """benchmarks/ first on sys.path, as when a script runs: they import their siblings.
    Afterwards the scripts leave no trace: their modules (top-level names such as `batch`
    or `units`) are dropped and the environment they set at import (OMP_NUM_THREADS) is
    restored."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    environ = dict(os.environ)
    yield
    for name, module in list(sys.modules.items()):
        if pathlib.Path(getattr(module, "__file__", None) or "/").parent == BENCHMARKS:
            del sys.modules[name]
    os.environ.clear()
    os.environ.update(environ)


def benchmark(name):
    """The module benchmarks/`name`.py, or a skip when it needs a peer package."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as err:
        if err.name in PEERS:
            pytest.skip(f"benchmarks/{name}.py needs {err.name}, not installed here")
        raise


def test_modules_found():
    assert len(MODULES) >= 30 and "resolve_python" in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_imports_and_answers_help(name):
    module = benchmark(name)
    if not hasattr(module, "main"):         # shared code of the other scripts
        return
    with contextlib.redirect_stdout(io.StringIO()) as out, pytest.raises(SystemExit) as exit_:
        module.main(["--help"])
    assert exit_.value.code == 0
    assert "usage:" in out.getvalue()


@pytest.mark.parametrize("name", sorted(QUICK))
def test_smallest_run(name, capsys):
    benchmark(name).main(QUICK[name])
    assert "load average" in capsys.readouterr().out
