"""Issue 43's one run of every driver on the Chaplygin sphere (a ball rolled to a goal
position and orientation): the verdict, `sample`, `accuracy=`, MPC, a batch, save/load and
the command line, each on the same problem. Oracles written here: the rolling rows
x_{k+1} - x_k = r P((R_k f_k) x e3) with f_k the Cayley coordinates of R_k^T R_{k+1}, the
goal as stated, |R^T R - I|, the interpolant's Cayley curve R_k cay(c f_k) with cay written
here, the cost of a 48-step solve as the truth of the accuracy target (its own error at
order 2 is a ninth of the 16-step one's), and the first MPC step, whose problem is the
original one, against the optimum's first control."""

import numpy as np
import pytest

import dmoc
from dmoc.cli import main

RADIUS, INERTIA, MASS, T = 0.7, (1.0, 1.5, 2.5), 1.3, 3.0
E3 = np.array([0.0, 0.0, 1.0])
GOAL_R = np.array([[0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])          # a quarter turn about e3
GOAL_X = np.array([1.0, 0.5])
FACTORY = f"""
import numpy as np
import dmoc

def roll():
    ball = dmoc.systems.chaplygin_sphere({INERTIA}, {MASS}, {RADIUS}, torques=True)
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, {T} / 6), 6, R_start=np.eye(3),
                                           R_goal=np.array({GOAL_R.tolist()}), x_start=[0, 0],
                                           x_goal={GOAL_X.tolist()})
"""


def roll(steps):
    ball = dmoc.systems.chaplygin_sphere(INERTIA, MASS, RADIUS, torques=True)
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, T / steps), steps, R_start=np.eye(3),
                                           R_goal=GOAL_R, x_start=[0, 0], x_goal=GOAL_X)


def hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def cay(f):
    """The Cayley map (I - f^/2)^-1 (I + f^/2)."""
    return np.linalg.solve(np.eye(3) - hat(f) / 2, np.eye(3) + hat(f) / 2)


def increments(R):
    """f_k with cay(f_k) = R_k^T R_{k+1}, shape (N, 3)."""
    F = np.einsum("kji,kjl->kil", R[:-1], R[1:])
    A = F - np.transpose(F, (0, 2, 1))
    return 2 * np.stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]], axis=1) / (1 + np.trace(F, axis1=1, axis2=2))[:, None]


def rolling_defect(traj):
    """max |x_{k+1} - x_k - r P((R_k f_k) x e3)| over the steps."""
    rolled = RADIUS * np.cross(np.einsum("kij,kj->ki", traj.R[:-1], increments(traj.R)), E3)[:, :2]
    return np.abs(np.diff(traj.x, axis=0) - rolled).max()


@pytest.fixture(scope="module")
def optimum():
    problem = roll(6)
    return problem, dmoc.optimize(problem)


def test_the_verdict_passes_an_optimum_that_rolls_to_its_goal(optimum):
    _, result = optimum
    traj = result.trajectory
    assert result.success and result.verdict.status == "passed"
    assert rolling_defect(traj) <= 1e-10
    assert np.abs(traj.R[-1] - GOAL_R).max() <= 1e-10 and np.abs(traj.x[-1] - GOAL_X).max() <= 1e-10


def test_sample_follows_each_steps_cayley_curve(optimum):
    traj = optimum[1].trajectory
    c = np.linspace(0.0, 1.0, 7)[1:-1]
    t = (traj.t[:-1, None] + c * traj.h).ravel()
    got = traj.sample(t)
    f = increments(traj.R)
    want = np.array([traj.R[k] @ cay(ci * f[k]) for k in range(traj.steps) for ci in c])
    assert np.abs(got.R - want).max() <= 1e-13
    assert np.abs(np.einsum("kji,kjl->kil", got.R, got.R) - np.eye(3)).max() <= 1e-13
    assert np.array_equal(traj.sample(traj.t).R, traj.R)


def test_an_accuracy_target_is_met_against_a_finer_solve():
    refined = dmoc.optimize(roll(8), accuracy=2e-2)
    truth = dmoc.optimize(roll(48)).cost
    assert refined.success and abs(refined.cost - truth) / truth <= 2e-2
    assert rolling_defect(refined.trajectory) <= 1e-10


def test_mpc_first_step_is_the_optimums_first_control_and_the_loop_steps_on(optimum):
    problem, result = optimum
    traj = result.trajectory
    controller = dmoc.MPC(problem)
    u = controller.step((np.eye(3), np.zeros(2)), v=np.zeros(5))
    assert np.abs(u - traj.u[0]).max() <= 1e-6 * (1 + np.abs(traj.u).max())
    controller.step((traj.R[1], traj.x[1]), p=traj.p[1])           # the plan's own next knot
    assert [s.success for s in controller.log] == [True, True] and controller.log[1].warm_start


def test_a_batch_replays_the_optimums_controls(optimum):
    problem, result = optimum
    traj = result.trajectory
    distributed = pytest.importorskip("distributed")
    run = {"q0": (traj.R[0], traj.x[0]), "p0": traj.p[0], "steps": traj.steps, "controls": traj.u}
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        (got,) = dmoc.batch.simulate_many(problem.disc, [run], client=client, progress=False)
    want = dmoc.simulate(problem.disc, **run).trajectory
    assert got.success and np.array_equal(got.trajectory.R, want.R) and np.array_equal(got.trajectory.x, want.x)
    assert np.abs(got.trajectory.R - traj.R).max() <= 1e-9 and np.abs(got.trajectory.x - traj.x).max() <= 1e-9


def test_a_saved_optimum_loads_bit_for_bit(optimum, tmp_path):
    result = optimum[1]
    result.save(tmp_path / "roll.npz")
    loaded = dmoc.OptimizationResult.load(tmp_path / "roll.npz")
    for name in ("R", "x", "p", "u", "t"):
        assert np.array_equal(getattr(loaded.trajectory, name), getattr(result.trajectory, name))
    assert loaded.cost == result.cost and loaded.verdict.status == "passed"


def test_the_command_line_writes_the_same_optimum(optimum, tmp_path):
    (tmp_path / "sphere.py").write_text(FACTORY)
    assert main(["optimize", f"{tmp_path / 'sphere.py'}:roll", "--no-plots", "--out", str(tmp_path / "out")]) == 0
    written = dmoc.RotationTrajectory.load(tmp_path / "out" / "roll.npz")
    assert np.abs(written.R - optimum[1].trajectory.R).max() <= 1e-12
    assert np.abs(written.x - optimum[1].trajectory.x).max() <= 1e-12
