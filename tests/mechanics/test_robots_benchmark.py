"""The chains benchmarks/robots.py measures (its smallest run is in
tests/test_benchmarks.py): URDF text that dmoc reads as a robot of n joints."""

import importlib.util
import pathlib

import pytest

pytest.importorskip("adam.casadi", reason="the robots extra (adam-robotics[casadi]) is not "
                    "installed: pip install -e '.[test]'")

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "benchmarks" / "robots.py"


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
