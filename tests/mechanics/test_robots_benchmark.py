"""benchmarks/robots.py at its smallest size (a two-joint chain, 20 steps in the virtual
machine): it still runs against today's code and prints its table. No figure is checked
(no timing in tests)."""

import importlib.util
import pathlib

import pytest

pytest.importorskip("adam.casadi", reason="the robots extra (adam-robotics[casadi]) is not "
                    "installed: pip install -e '.[test]'")

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "benchmarks" / "robots.py"


def test_smallest_run(capsys, monkeypatch):
    monkeypatch.delenv("DMOC_CACHE_DIR", raising=False)    # main() sets its own: restored after
    spec = importlib.util.spec_from_file_location("robots_benchmark", SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    script.main(["--joints", "2", "--steps", "20", "--no-compile"])
    out = capsys.readouterr().out
    assert "load average" in out and "| chain-2 | 2 |" in out


def test_the_generated_chain_is_a_urdf_of_n_joints(tmp_path):
    """The chains the benchmark measures are read as n-joint robots."""
    import dmoc
    spec = importlib.util.spec_from_file_location("robots_benchmark", SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    path = tmp_path / "chain5.urdf"
    path.write_text(script.chain_urdf(5))
    system = dmoc.RobotSystem(path)
    assert system.n == 5 and system.names == ("j1", "j2", "j3", "j4", "j5")
