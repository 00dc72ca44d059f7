"""The `dmoc` command: every subcommand, every exit code (0 success, 1 solver failure with its
files written, 2 bad argument in one line), and no traceback reaching the terminal."""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import dmoc
from dmoc.cli import main

ROOT = pathlib.Path(__file__).parents[2]

SLEIGH = '''
import casadi as ca
import dmoc


def sleigh(mass=1.0, inertia=0.5, offset=0.3):
    """Chaplygin sleigh: blade at the origin of the body frame, centre of mass `offset` ahead."""
    def lagrangian(q, v):
        c, s = ca.cos(q[2]), ca.sin(q[2])
        vx = v[0] - offset * s * v[2]
        vy = v[1] + offset * c * v[2]
        return mass / 2 * (vx ** 2 + vy ** 2) + inertia / 2 * v[2] ** 2

    return dmoc.MechanicalSystem(
        lagrangian, 3, constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
        force=lambda q, v, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]),
        n_u=2, names=("x", "y", "theta"))


def blowup():
    """L = v^2/2 with the force v^2 + u: the midpoint step has no real solution once
    1 - 2h (p_k + h u_k / 2) < 0."""
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2, 1,
                                 force=lambda q, v, u: v[0] ** 2 + u[0], n_u=1)


def not_a_system():
    return 42
'''


@pytest.fixture(scope="module")
def user_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("user") / "my_systems.py"
    path.write_text(SLEIGH)
    return path


def _one_line_error(capsys, argument):
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("dmoc: error")]
    assert len(lines) == 1 and argument in lines[0], err
    assert "Traceback" not in err
    return lines[0]


def test_version_and_systems(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"dmoc {__import__('importlib.metadata').metadata.version('dmoc')}"
    assert main(["systems"]) == 0
    listed = capsys.readouterr().out
    for word in ("knife-edge", "rolling-disk", "mass=1.0", "incline=0.0", "radius=1.0",
                 "--goal 1,1,free,1.5708", "file.py:factory"):
        assert word in listed


def test_optimize_built_in_writes_every_file(tmp_path, capsys):
    assert main(["optimize", "knife-edge", "--steps", "20", "--out", str(tmp_path), "--animate"]) == 0
    out = capsys.readouterr().out
    assert "Solve_Succeeded" in out
    names = {p.name for p in tmp_path.iterdir()}
    assert {"knife_edge.npz", "knife_edge.csv", "knife_edge_summary.json", "knife_edge.gif",
            "knife_edge_path.png", "knife_edge_states.png", "knife_edge_controls.png",
            "knife_edge_constraint.png", "knife_edge_energy.png"} <= names
    traj = dmoc.Trajectory.load(tmp_path / "knife_edge.npz")
    np.testing.assert_allclose(traj.q[-1], [0, 1, 0], atol=1e-10)
    header = (tmp_path / "knife_edge.csv").read_text().splitlines()[0]
    assert header == "t,x,y,theta,p_x,p_y,p_theta,lam_0,force,torque"
    table = np.loadtxt(tmp_path / "knife_edge.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 1:4], traj.q)
    summary = json.loads((tmp_path / "knife_edge_summary.json").read_text())
    assert summary["success"] is True and summary["iterations"] > 0
    for key in ("cost", "build_time", "solve_time", "max_violation", "energy_drift", "replay_q"):
        assert np.isfinite(summary[key])
    assert summary["replay_q"] < 1e-8


def test_optimize_user_system_with_free_goal_and_params(user_file, tmp_path, capsys):
    argv = ["optimize", f"{user_file}:sleigh", "--param", "offset=0.2", "--goal", "1,0.5,free",
            "--steps", "20", "--duration", "3", "--variant", "-", "--rule", "trapezoid",
            "--out", str(tmp_path), "--animate"]
    assert main(argv) == 0
    summary = json.loads((tmp_path / "sleigh_summary.json").read_text())
    assert summary["status"] == "Solve_Succeeded" and summary["variant"] == "-"
    traj = dmoc.Trajectory.load(tmp_path / "sleigh.npz")
    np.testing.assert_allclose(traj.q[-1, :2], [1, 0.5], atol=1e-10)
    assert (tmp_path / "sleigh.gif").stat().st_size > 1000
    assert "u0,u1" in (tmp_path / "sleigh.csv").read_text().splitlines()[0]


def test_simulate_built_in_and_controls_file(user_file, tmp_path, capsys):
    assert main(["simulate", "rolling-disk", "--steps", "50", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "rolling_disk_summary.json").read_text())
    assert summary["max_constraint_violation"] < 1e-12 and summary["energy_drift"] < 1e-10
    controls = tmp_path / "u.csv"
    controls.write_text("force,torque\n" + "1.0,0.5\n" * 8)
    assert main(["simulate", f"{user_file}:sleigh", "--controls", str(controls),
                 "--start", "0,0,0", "--velocity", "0,0,0", "--duration", "0.8"]) == 0
    assert "completed_steps           8" in capsys.readouterr().out


def test_newton_failure_exits_1_and_keeps_the_steps_before(user_file, tmp_path, capsys):
    controls = np.zeros(10)
    controls[5] = 100.0                  # no real solution at step 5 (see the file)
    np.save(tmp_path / "u.npy", controls)
    argv = ["simulate", f"{user_file}:blowup", "--controls", str(tmp_path / "u.npy"),
            "--start", "0", "--velocity", "1", "--duration", "1", "--out", str(tmp_path)]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "solver failed (newton_failed)" in err and "step 5" in err
    summary = json.loads((tmp_path / "blowup_summary.json").read_text())
    assert summary["success"] is False and summary["completed_steps"] == 5
    assert dmoc.Trajectory.load(tmp_path / "blowup.npz").steps == 5


def test_ipopt_failure_exits_1_and_writes_the_last_iterate(tmp_path, capsys):
    argv = ["optimize", "knife-edge", "--steps", "20", "--max-iter", "2", "--out", str(tmp_path)]
    assert main(argv) == 1
    assert "solver failed (Maximum_Iterations_Exceeded)" in capsys.readouterr().err
    summary = json.loads((tmp_path / "knife_edge_summary.json").read_text())
    assert summary["success"] is False and summary["iterations"] == 2
    assert dmoc.Trajectory.load(tmp_path / "knife_edge.npz").steps == 20
    assert (tmp_path / "knife_edge_path.png").exists()


@pytest.mark.parametrize("argv, argument", [
    (["optimize", "knife-edge", "--steps", "0"], "--steps"),
    (["optimize", "knife-edge", "--duration", "-1"], "--duration"),
    (["optimize", "knife-edge", "--goal", "1,2"], "--goal"),
    (["optimize", "knife-edge", "--goal", "1,2,x"], "--goal"),
    (["optimize", "knife-edge", "--rule", "simpson"], "--rule"),
    (["optimize", "knife-edge", "--variant", "0"], "--variant"),
    (["optimize", "knife-edge", "--param", "mass=-1"], "--param"),
    (["optimize", "knife-edge", "--param", "colour=1"], "--param"),
    (["optimize", "knife-edge", "--param", "mass"], "--param"),
    (["optimize", "knife-edge", "--animate"], "--animate"),
    (["simulate", "knife-edge", "--velocity", "0,1,0"], "--velocity"),
    (["simulate", "knife-edge", "--start", "0,free,0"], "--start"),
    (["simulate", "knife-edge", "--controls", "missing.csv"], "--controls"),
    (["simulate", "no-such-system"], "SYSTEM"),
    (["simulate", "missing.py:factory"], "SYSTEM"),
    (["simulate"], "SYSTEM"),
    (["frobnicate"], "COMMAND"),
])
def test_bad_argument_exits_2_with_one_line(argv, argument, capsys):
    assert main(argv) == 2
    _one_line_error(capsys, argument)


@pytest.mark.parametrize("factory, argument", [("not_a_system", "MechanicalSystem"),
                                               ("missing", "no callable")])
def test_bad_user_factory(user_file, factory, argument, capsys):
    assert main(["simulate", f"{user_file}:{factory}"]) == 2
    _one_line_error(capsys, argument)


def test_controls_of_the_wrong_shape(tmp_path, capsys):
    np.save(tmp_path / "u.npy", np.zeros((5, 3)))
    assert main(["simulate", "knife-edge", "--controls", str(tmp_path / "u.npy")]) == 2
    assert "(N, 2)" in _one_line_error(capsys, "--controls")


def test_unwritable_output_folder(tmp_path, capsys):
    (tmp_path / "file").write_text("")
    assert main(["demo", "--out", str(tmp_path / "file" / "sub")]) == 2
    _one_line_error(capsys, "--out")


def test_demo_solver_failure_exits_1_and_writes_summary(tmp_path, capsys):
    assert main(["demo", "--steps", "20", "--opt-steps", "2", "--out", str(tmp_path)]) == 1
    assert "Infeasible_Problem_Detected" in (tmp_path / "summary.txt").read_text()
    assert (tmp_path / "knife_edge_parking_plus.npz").exists()


def _run(*argv, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "dmoc", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def test_subprocess_exit_codes_and_no_traceback(tmp_path):
    bad = _run("optimize", "knife-edge", "--steps", "two", cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--steps" in bad.stderr
    failed = _run("optimize", "rolling-disk", "--steps", "10", "--max-iter", "1", "--out", "o",
                  cwd=tmp_path)
    assert failed.returncode == 1 and "Maximum_Iterations_Exceeded" in failed.stderr
    assert (tmp_path / "o" / "rolling_disk_summary.json").exists()
    assert "Traceback" not in bad.stderr + failed.stderr


@pytest.mark.parametrize("system", ["spherical-pendulum", "lc-circuit"])
def test_later_built_ins_simulate_and_optimize(system, tmp_path, capsys):
    assert main(["simulate", system, "--steps", "50", "--out", str(tmp_path / "s")]) == 0
    assert main(["optimize", system, "--steps", "30", "--out", str(tmp_path / "o")]) == 0
    summary = json.loads(next((tmp_path / "o").glob("*_summary.json")).read_text())
    assert summary["success"] and summary["replay_q"] < 1e-8


def test_stage_rule_csv_names_the_controls_by_node(tmp_path, capsys):
    assert main(["optimize", "knife-edge", "--rule", "lobatto3", "--steps", "12",
                 "--out", str(tmp_path)]) == 0
    header = (tmp_path / "knife_edge.csv").read_text().splitlines()[0].split(",")
    assert header[-6:] == ["force@0", "torque@0", "force@0.5", "torque@0.5", "force@1", "torque@1"]
    table = np.loadtxt(tmp_path / "knife_edge.csv", delimiter=",", skiprows=1)
    assert table.shape[1] == len(header)
