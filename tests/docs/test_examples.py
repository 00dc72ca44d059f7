"""End-to-end: the two DMOC examples and the `dmoc demo` command run, converge, write their
files, and their optima are replayed exactly by the simulator."""

import importlib.util
import pathlib

import numpy as np
import pytest

from dmoc import Trajectory
from dmoc.cli import main

EXAMPLES = pathlib.Path(__file__).parents[2] / "examples"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", ["knife_edge_parking", "rolling_disk_steering"])
def test_example_runs_and_saves(name, tmp_path, capsys):
    result = _load(name).main(steps=40, out=tmp_path)
    assert result.success
    printed = capsys.readouterr().out
    assert "cost" in printed and "replay by simulate" in printed
    for suffix in ("_path.png", "_controls.png"):
        assert (tmp_path / f"{name}{suffix}").stat().st_size > 1000
    saved = Trajectory.load(tmp_path / f"{name}.npz")
    assert np.array_equal(saved.q, result.trajectory.q)
    goal = {"knife_edge_parking": [0, 1, 0], "rolling_disk_steering": [1, 1, np.nan, np.pi / 2]}[name]
    fixed = np.isfinite(goal)
    assert np.array_equal(saved.q[0], np.zeros_like(saved.q[0]))
    assert np.allclose(saved.q[-1, fixed], np.asarray(goal)[fixed], rtol=0, atol=1e-12)


def test_demo_command_writes_summary(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--steps", "200", "--opt-steps", "30"]) == 0
    summary = (tmp_path / "summary.txt").read_text()
    assert summary.count("Solve_Succeeded") == 4
    assert "knife_edge" in summary and "rolling_disk" in summary
    for figure in ("simulation", "knife_edge_parking", "rolling_disk_steering"):
        assert (tmp_path / f"{figure}.png").stat().st_size > 1000


def test_demo_command_rejects_bad_steps(capsys):
    assert main(["demo", "--steps", "0"]) == 2
    assert "--steps" in capsys.readouterr().err


@pytest.mark.parametrize("name, files", [
    ("lc_circuit", ["charges", "energy", "steering", "controls", "balance"]),
    ("point_vortices", ["pair", "triple"]),
])
def test_degenerate_example_runs_and_saves(name, files, tmp_path, capsys):
    result = _load(name).main(steps=40, out=tmp_path)
    printed = capsys.readouterr().out
    assert printed == (tmp_path / f"{name}_summary.txt").read_text()
    for suffix in files:
        assert (tmp_path / f"{name}_{suffix}.png").stat().st_size > 1000
    if name == "lc_circuit":
        assert result.success and "replay by simulate" in printed
        assert np.allclose(Trajectory.load(tmp_path / "lc_circuit_steering.npz").q[-1],
                           [1.0, 0.25, 0.75], rtol=0, atol=1e-12)
    else:
        assert "Omega: measured" in printed and result.steps == 400
