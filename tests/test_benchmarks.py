"""The scripts of benchmarks/ against today's code: each runs at its smallest size, and each is
named in docs/performance.md. Their figures are not checked here (no timing in tests): only
that they still run to their end.
"""

import contextlib
import importlib
import io
import os
import pathlib
import re
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
MODULES = sorted(path.stem for path in BENCHMARKS.glob("*.py"))
# code the scripts share, run through the scripts that import it
SHARED = {"collocation": "dmoc_vs_collocation"}
# each script's smallest run: a few seconds on a warm compile cache
SMALLEST = {
    "accuracy": ["--smallest"],
    "batch": ["--count", "8", "--sim-steps", "20", "--repeat", "1"],
    "dmoc_vs_collocation": ["--smallest"],
    "mpc": ["--horizon", "10", "--steps", "3", "--repeat", "1", "--tracking", "--sphere"],
    "peers": ["first", "--smallest"],
    "resolve": ["--smallest", "--sensitivities"],
    "robots": ["--smallest"],
    "scaling": ["--steps", "50", "100", "--repeat", "1"],
    "step_cost": ["--smallest"],
    "verdict": ["--smallest"],
    "warm_options": ["--quick"],
    "work_precision": ["--smallest"],
}


@pytest.fixture(autouse=True)
def benchmarks_path(monkeypatch):
    """benchmarks/ first on sys.path, as when a script runs: they import their siblings.
    Afterwards the scripts leave no trace: their modules (top-level names such as `batch`
    or `resolve`) are dropped, the environment they set at import (OMP_NUM_THREADS) is
    restored, and no bytecode is left in benchmarks/ (nor by the children they start)."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    environ = dict(os.environ)
    yield
    for name, module in list(sys.modules.items()):
        if pathlib.Path(getattr(module, "__file__", None) or "/").parent == BENCHMARKS:
            del sys.modules[name]
    os.environ.clear()
    os.environ.update(environ)


def test_every_script_is_run_here_and_named_in_the_docs():
    performance = (ROOT / "docs" / "performance.md").read_text()
    assert len(MODULES) <= 15
    assert sorted([*SMALLEST, *SHARED]) == MODULES
    assert set(SHARED.values()) <= set(SMALLEST)
    for name in MODULES:
        assert f"{name}.py" in performance, name


def test_the_performance_page_is_a_reference_not_a_log():
    """docs/performance.md holds today's figures (issue 39): at most 800 lines, and no
    section headed as a round, a pass or a stage of development ("Third round", "ninth
    pass", ...)."""
    lines = (ROOT / "docs" / "performance.md").read_text().splitlines()
    assert len(lines) <= 800
    log_titles = re.compile(r"\b(round|rounds|pass|passes|stage \d+|first|second|third|fourth|"
                            r"fifth|sixth|seventh|eighth|ninth|tenth)\b", re.IGNORECASE)
    assert [h for h in lines if h.startswith("#") and log_titles.search(h)] == []


@pytest.mark.parametrize("name", sorted(SMALLEST))
def test_smallest_run(name, capsys):
    importlib.import_module(name).main(SMALLEST[name])
    out = capsys.readouterr().out
    assert out.strip(), f"benchmarks/{name}.py printed nothing"


def test_verdict_study_slice(capsys):
    """The verdict study of issue 40 (`verdict.py --study`) on its first 2 problems of seed
    40: both optima right (against the truth of the continuous problem) and passed."""
    importlib.import_module("verdict").main(["--study", "2"])
    out = capsys.readouterr().out
    assert "counts, with the estimate (estimate=True): true success 2, false success 0" in out
    assert "counts, default verdict: true success 2, false success 0" in out


def test_peers_says_when_the_peer_side_is_skipped(capsys):
    importlib.import_module("peers").main(["resolve", "--smallest"])
    importlib.import_module("peers").main(["mpc", "--smallest"])
    importlib.import_module("peers").main(["nlp", "--smallest"])
    out = capsys.readouterr().out
    if importlib.util.find_spec("rockit") is None:
        assert "the peer side is skipped" in out
    assert "lobatto4" in out and "dmoc.MPC" in out and "IPOPT's solve alone over N" in out


def test_peer_side():
    if importlib.util.find_spec("rockit") is None:
        pytest.skip("rockit is not installed: benchmarks/peers.py's peer side runs in the "
                    "environment its docstring names")
    with contextlib.redirect_stdout(io.StringIO()) as out:
        importlib.import_module("peers").main(["first", "--smallest"])
    assert "rockit, N = " in out.getvalue()
