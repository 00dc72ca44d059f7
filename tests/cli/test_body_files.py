"""The command line takes a rigid body on SO(3): a file's factory returning a RigidBody
(``dmoc simulate``, and ``dmoc optimize`` with --goal as a rotation vector) or a
GroupOptimalControlProblem (``dmoc optimize``), through the real entry point. Oracles,
written here: the start rotation of --start from scipy's rotation vector, the rolling
x_{k+1} - x_k = r P((R_k f_k) x e3) with f_k the Cayley coordinates of R_k^T R_{k+1}, the
goal as the factory states it, |R^T R - I| of every knot, and the summary against the
written trajectory; with --animate a GIF of one frame per knot."""

import json

import numpy as np
import pytest
from PIL import Image
from scipy.spatial.transform import Rotation

import dmoc
from dmoc.cli import main

RADIUS, E3 = 0.7, np.array([0.0, 0.0, 1.0])
GOAL = np.array([[0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])          # a quarter turn about e3
FACTORIES = f"""
import numpy as np
import dmoc

def ball(mass=1.3):
    return dmoc.systems.chaplygin_sphere((1.0, 1.5, 2.5), mass, {RADIUS}, torques=True)

def roll(steps=6):
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(ball(), 0.5), steps, R_start=np.eye(3),
                                           R_goal=np.array({GOAL.tolist()}), x_start=[0, 0],
                                           x_goal=[1.0, 0.5])
"""


@pytest.fixture(scope="module")
def bodies(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bodies")
    (folder / "bodies.py").write_text(FACTORIES)
    return folder


def rolled(traj):
    """r P((R_k f_k) x e3) of every step, shape (N, 2)."""
    F = np.einsum("kji,kjl->kil", traj.R[:-1], traj.R[1:])
    A = F - np.transpose(F, (0, 2, 1))
    f = 2 * np.stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]], axis=1) / (1 + np.trace(F, axis1=1, axis2=2))[:, None]
    return RADIUS * np.cross(np.einsum("kij,kj->ki", traj.R[:-1], f), E3)[:, :2]


def test_simulate_rolls_a_ball_from_a_rotation_vector_start(bodies, capsys):
    out, R0 = bodies / "sim", Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    rolling = RADIUS * np.cross(R0 @ [1.0, 0, 0], E3)[:2]          # x' of Omega = e1 at R0
    code = main(["simulate", f"{bodies / 'bodies.py'}:ball", "--steps", "20", "--duration", "2",
                 "--start", "0.3,-0.2,0.5,0.1,0.2", "--velocity", ",".join(repr(float(v)) for v in [1.0, 0, 0, *rolling]),
                 "--out", str(out)])
    assert code == 0
    traj = dmoc.RotationTrajectory.load(out / "ball.npz")
    assert np.abs(traj.R[0] - R0).max() <= 1e-15
    assert np.array_equal(traj.x[0], [0.1, 0.2]) and traj.steps == 20 and traj.h == 0.1
    assert np.abs(np.diff(traj.x, axis=0) - rolled(traj)).max() <= 1e-13
    summary = json.loads((out / "ball_summary.json").read_text())
    assert summary["success"] and summary["max_orthogonality_defect"] == traj.orthogonality_defect.max()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["ball.npz", "ball_path.png", "ball_states.png",
                                                     "ball_summary.json"]
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("command", [["roll"], ["ball", "--goal", f"0,0,{np.pi / 2!r},1,0.5", "--steps", "6",
                                                "--duration", "3"]])
def test_optimize_rolls_the_ball_to_its_goal_from_a_problem_or_a_body(bodies, command):
    out = bodies / command[0]
    assert main(["optimize", f"{bodies / 'bodies.py'}:{command[0]}", *command[1:], "--no-plots",
                 "--animate", "--out", str(out)]) == 0
    with Image.open(out / f"{command[0]}.gif") as gif:           # --animate: the GIF alone
        assert gif.n_frames == 7
    assert not (out / f"{command[0]}_path.png").exists()
    traj = dmoc.RotationTrajectory.load(out / f"{command[0]}.npz")
    assert np.abs(traj.R[-1] - GOAL).max() <= 1e-10 and np.abs(traj.x[-1] - [1.0, 0.5]).max() <= 1e-10
    assert np.abs(np.diff(traj.x, axis=0) - rolled(traj)).max() <= 1e-10
    # the NLP holds the group rows q_{k+1} = R_k cay(f_k) to IPOPT's final violation (1.4e-13
    # here); the optimum's R_k are orthogonalized, so orthogonal to round-off
    assert traj.orthogonality_defect.max() <= 1e-14 and traj.t[-1] == 3.0
    summary = json.loads((out / f"{command[0]}_summary.json").read_text())
    assert summary["success"] and summary["replay_deviation"] <= 1e-10
    assert summary["cost"] == pytest.approx(0.5 * np.sum(traj.u ** 2), rel=1e-12)


@pytest.mark.parametrize("command, message", [
    (["simulate", "ball", "--rule", "lobatto3"], "argument --rule: is not taken for a rigid body on SO(3)"),
    (["simulate", "ball", "--controls", "u.npy"], "argument --controls: is not taken for a rigid body"),
    (["simulate", "ball", "--animate"], "argument --animate: needs --out DIR"),
    (["optimize", "roll", "--steps", "4"], "argument --steps: is stated by the problem"),
    (["optimize", "ball"], "argument --goal: is required for a rigid body"),
    (["optimize", "ball", "--goal", "0,0,1"], "argument --goal: must have 5 entries (phi1, phi2, phi3, x1, x2)"),
    (["simulate", "ball", "--velocity", "1,0,0,0,0"], "argument --velocity: the velocity of `v0`"),
])
def test_options_a_body_does_not_take_are_refused_by_name(bodies, capsys, command, message):
    command[1] = f"{bodies / 'bodies.py'}:{command[1]}"
    assert main(command) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
