"""The command line states a robotics problem: a file's factory returns a whole
OptimalControlProblem (examples/lane_change_problem.py), the options give bounds, a free
final time and a start velocity, and ``simulate --controls NAME.csv`` replays an optimum
with the step and start of its table.

Oracles: the bounds, the obstacle and the goal as written in the example, checked on the
written files by closed forms in this file (distances to a disc, the car's Legendre
transform p = M v); the replay against the optimum; for the free final time of the flat
knife edge the exact time scaling of rest-to-rest optima, J(T) = J(T_0) (T_0/T)^3."""

import importlib.util
import json
import sys
import pathlib

import numpy as np
import pytest

import dmoc
from dmoc.cli import main

ROOT = pathlib.Path(__file__).parents[2]
LANE_CHANGE = ROOT / "examples" / "lane_change_problem.py"
SYSTEM = f"{LANE_CHANGE}:lane_change"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("lane_change_problem", LANE_CHANGE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    """`dmoc optimize lane_change_problem.py:lane_change --out out`, as the issue states it."""
    out = tmp_path_factory.mktemp("lane_change")
    code = main(["optimize", SYSTEM, "--heading", "theta", "--out", str(out)])
    return code, out


def _table(path):
    header = path.read_text().splitlines()[0].split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1)


def test_lane_change_is_bounded_free_time_and_clear_of_the_obstacle(solved, example):
    code, out = solved
    assert code == 0
    summary = json.loads((out / "lane_change_summary.json").read_text())
    assert summary["success"] and summary["free_time"] and summary["steps"] == 60
    traj = dmoc.Trajectory.load(out / "lane_change.npz")
    assert 0.5 + 0.1 < traj.t[-1] < 8.0 - 0.1                    # T free, inside its range
    force, torque = traj.u.T
    assert force.min() >= -2 * example.FORCE - 1e-9 and force.max() <= example.FORCE + 1e-9
    assert np.abs(torque).max() <= example.TORQUE + 1e-9
    assert np.abs(torque).max() > example.TORQUE - 1e-6          # the torque bound is active
    # the disc, at the step midpoints where the path constraint is imposed
    mid = (traj.q[1:] + traj.q[:-1]) / 2
    front = mid[:, :2] + 2.7 * np.column_stack([np.cos(mid[:, 2]), np.sin(mid[:, 2])])
    clearance = np.hypot(*(np.vstack([mid[:, :2], front]) - example.OBSTACLE).T)
    assert clearance.min() > example.RADIUS - 1e-8
    assert clearance.min() < example.RADIUS + 1e-6               # and it is in the way
    np.testing.assert_allclose(traj.q[-1, 1:], [example.LANE, 0, 0], atol=1e-9)
    # start velocity (10, 0, 0, 0): p = M v with the car's mass 1500 kg on x
    np.testing.assert_allclose(traj.p[0], [1500.0 * example.SPEED, 0, 0, 0], atol=1e-6)
    assert (out / "lane_change_path.png").exists()


def test_simulate_replays_the_table_optimize_wrote(solved, tmp_path, capsys):
    _, out = solved
    assert main(["simulate", SYSTEM, "--controls", str(out / "lane_change.csv"),
                 "--out", str(tmp_path), "--no-plots"]) == 0
    optimum = dmoc.Trajectory.load(out / "lane_change.npz")
    replay = dmoc.Trajectory.load(tmp_path / "lane_change.npz")
    np.testing.assert_allclose(replay.t, optimum.t, rtol=1e-13, atol=0)   # the run's h
    np.testing.assert_allclose(replay.q, optimum.q, rtol=0, atol=1e-8)
    np.testing.assert_allclose(replay.p, optimum.p, rtol=1e-10, atol=1e-6)
    assert not list(tmp_path.glob("*.png"))                             # --no-plots


def test_a_replay_refuses_another_duration(solved, capsys):
    _, out = solved
    assert main(["simulate", SYSTEM, "--controls", str(out / "lane_change.csv"),
                 "--duration", "10"]) == 2
    err = capsys.readouterr().err
    assert "argument --duration" in err and "t column" in err


def test_controls_without_times_need_a_duration(tmp_path, capsys):
    np.save(tmp_path / "u.npy", np.zeros((5, 2)))
    assert main(["simulate", "knife-edge", "--controls", str(tmp_path / "u.npy")]) == 2
    assert "argument --duration: is required" in capsys.readouterr().err


@pytest.mark.parametrize("option, value", [("--steps", "10"), ("--rule", "trapezoid"),
                                           ("--duration", "3"), ("--control-max", "1,1"),
                                           ("--free-time", "1,2"), ("--velocity-max", "1,1,1")])
def test_a_problem_refuses_the_options_it_states(option, value, capsys):
    assert main(["optimize", SYSTEM, option, value]) == 2
    err = capsys.readouterr().err
    assert f"argument {option}: is stated by the problem" in err and "--param" in err


PARKING = '''
import casadi as ca
import dmoc


def parking(steps=20):
    """The knife edge around a disc at (-0.1, 0.5) of radius 0.2."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / steps)
    return dmoc.OptimalControlProblem(
        disc, steps, q_start=[0, 0, 0], q_goal=[0, 1, 0],
        path_constraints=lambda q, v, u: 0.04 - ca.sumsqr(q[:2] - ca.DM([-0.1, 0.5])))
'''


def test_boundary_options_change_a_given_problem(tmp_path, capsys):
    (tmp_path / "parking.py").write_text(PARKING)
    assert main(["optimize", f"{tmp_path}/parking.py:parking", "--param", "steps=24",
                 "--goal", "0.2,1.2,0", "--out", str(tmp_path)]) == 0
    traj = dmoc.Trajectory.load(tmp_path / "parking.npz")
    assert traj.steps == 24
    np.testing.assert_allclose(traj.q[-1], [0.2, 1.2, 0], atol=1e-10)


def _optimum(tmp_path, *options):
    argv = ["optimize", "knife-edge", "--steps", "20", *options, "--out", str(tmp_path)]
    assert main(argv) == 0
    summary = json.loads((tmp_path / "knife_edge_summary.json").read_text())
    return summary, dmoc.Trajectory.load(tmp_path / "knife_edge.npz")


def test_free_final_time_follows_the_time_scaling(tmp_path, capsys):
    """Rest to rest on the flat knife edge, q(t/a) is an optimum for T a with controls
    u/a^2, so J(T) = J(4) (4/T)^3: the free final time goes to T_max = 6."""
    fixed, _ = _optimum(tmp_path / "fixed")
    free, traj = _optimum(tmp_path / "free", "--free-time", "2,6")
    assert free["free_time"] and traj.t[-1] == pytest.approx(6.0, rel=1e-8)
    assert free["cost"] == pytest.approx(fixed["cost"] * (4 / 6) ** 3, rel=1e-7)


def test_control_and_state_bounds_hold(tmp_path, capsys):
    unbounded, _ = _optimum(tmp_path / "unbounded")
    bounded, traj = _optimum(tmp_path / "bounded", "--control-min", "-0.8,none",
                             "--control-max", "0.8,none", "--state-min", "none,none,-1.2",
                             "--state-max", "none,none,1.2")
    assert np.abs(traj.u[:, 0]).max() == pytest.approx(0.8, abs=1e-7)
    assert np.abs(traj.q[:, 2]).max() == pytest.approx(1.2, abs=1e-7)
    assert bounded["cost"] > unbounded["cost"]


def test_velocity_bounds_hold(tmp_path, capsys):
    """--velocity-min/--velocity-max bound the heading rate, 1.07 unbounded, to 0.6: on the
    midpoint rule at each step's midpoint, (q_{k+1} - q_k)/h."""
    unbounded, free_traj = _optimum(tmp_path / "unbounded")
    bounded, traj = _optimum(tmp_path / "bounded", "--velocity-min", "none,none,-0.6",
                             "--velocity-max", "none,none,0.6")
    assert np.abs(free_traj.velocities[:, 2]).max() > 1.0
    assert np.abs(traj.velocities[:, 2]).max() == pytest.approx(0.6, abs=1e-7)
    assert bounded["cost"] > unbounded["cost"]


def test_start_velocity(tmp_path, capsys):
    """A start velocity (1, 0, 0) along the blade: p_0 = m v_0 with m = 1."""
    _, traj = _optimum(tmp_path, "--velocity", "1,0,0")
    np.testing.assert_allclose(traj.p[0], [1, 0, 0], atol=1e-9)
    header, table = _table(tmp_path / "knife_edge.csv")
    np.testing.assert_array_equal(table[0, header.index("p_x")], traj.p[0, 0])


def test_heading_by_name(tmp_path, monkeypatch, capsys):
    drawn = {}

    def record(traj, out, name, **kwargs):
        drawn.update(kwargs)
        return []

    monkeypatch.setattr("dmoc.cli.output.save_trajectory_plots", record)
    assert main(["simulate", f"{LANE_CHANGE}:lane_change", "--heading", "theta", "--steps",
                 "5", "--duration", "0.5", "--out", str(tmp_path)]) == 0
    assert drawn["heading"] == 2
    assert main(["simulate", "knife-edge", "--heading", "phi", "--steps", "5"]) == 2
    assert "argument --heading: must be one of the coordinates x, y, theta" in capsys.readouterr().err


def test_bad_options_of_a_problem_exit_2_with_one_line(solved, tmp_path, capsys):
    """A table of another system, bounds the wrong way round, a free time range that is
    not a pair: one line naming the option."""
    _, out = solved
    cases = [(["simulate", "knife-edge", "--controls", str(out / "lane_change.csv")],
              "argument --controls", "written for another system"),
             (["optimize", "knife-edge", "--control-min", "1,none", "--control-max", "0,none"],
              "argument --control-min/--control-max", "`control_bounds` must satisfy lower <= upper"),
             (["optimize", "knife-edge", "--free-time", "2"], "argument --free-time",
              "must have 2 entries (TMIN, TMAX)")]
    for argv, argument, words in cases:
        assert main(argv) == 2
        lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
        assert len(lines) == 1 and argument in lines[0] and words in lines[0], lines


@pytest.mark.parametrize("rule, variant", [("midpoint", "-"), ("lobatto3", "+"), ("trapezoid", "+")])
def test_the_replay_of_any_rule_and_variant(rule, variant, tmp_path, capsys):
    """The table of a stage rule (controls at its nodes, e.g. force@0.5) and of the (-)
    variant replays its optimum, from the table's start (q_0, p_0) and step."""
    options = ["--rule", rule, "--variant", variant]
    assert main(["optimize", "rolling-disk", "--steps", "12", *options,
                 "--out", str(tmp_path / "o"), "--no-plots"]) == 0
    assert main(["simulate", "rolling-disk", *options, "--controls",
                 str(tmp_path / "o" / "rolling_disk.csv"), "--out", str(tmp_path / "s"),
                 "--no-plots"]) == 0
    optimum = dmoc.Trajectory.load(tmp_path / "o" / "rolling_disk.npz")
    replay = dmoc.Trajectory.load(tmp_path / "s" / "rolling_disk.npz")
    np.testing.assert_allclose(replay.t, optimum.t, rtol=1e-14, atol=0)
    np.testing.assert_allclose(replay.q, optimum.q, rtol=0, atol=1e-9)


def test_the_example_script_solves_and_replays(example, tmp_path, capsys):
    assert example.main(steps=30, out=tmp_path) == (0, 0)
    assert dmoc.Trajectory.load(tmp_path / "lane_change.npz").steps == 30


def test_a_problem_file_imports_a_module_beside_it(tmp_path, monkeypatch, capsys):
    """`dmoc optimize dir/problem.py:factory` with dir/ off sys.path and off the working
    folder: the file's `import` of dir/parking_goal_42.py finds it (the goal it holds is
    the optimum's last q), and sys.path is as it was afterwards."""
    folder = tmp_path / "dir"
    folder.mkdir()
    (folder / "parking_goal_42.py").write_text("GOAL = [0.2, 1.2, 0.0]\n")
    (folder / "problem.py").write_text(
        "import dmoc\nfrom parking_goal_42 import GOAL\n\n\n"
        "def factory():\n"
        "    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / 24)\n"
        "    return dmoc.OptimalControlProblem(disc, 24, q_start=[0, 0, 0], q_goal=GOAL)\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delitem(sys.modules, "parking_goal_42", raising=False)
    before = list(sys.path)
    try:
        assert main(["optimize", "dir/problem.py:factory", "--out", str(tmp_path / "out"),
                     "--no-plots"]) == 0
    finally:
        sys.modules.pop("parking_goal_42", None)
    assert sys.path == before
    traj = dmoc.Trajectory.load(tmp_path / "out" / "factory.npz")
    np.testing.assert_allclose(traj.q[-1], [0.2, 1.2, 0.0], atol=1e-10)
