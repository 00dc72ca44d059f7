"""DMOC on SO(3): the rest-to-rest slew of a spacecraft with equal principal inertias I through
an angle theta about a fixed axis e in time T, min integral |tau|^2. Its optimum (written
here, not from dmoc) is the eigenaxis rotation R(t) = exp(theta(t) e^) with theta(t) =
theta (3 s^2 - 2 s^3), s = t/T, of cost J* = 12 I^2 theta^2 / T^3: I theta'' = tau (the
gyroscopic term Omega x I Omega vanishes), and the cubic is the minimum-effort rest-to-rest
profile. The discrete optimum must reach J* at order 2 and replay in the simulator."""

import signal

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc

I, THETA, T = 2.0, 1.2, 2.0
AXIS = np.array([1.0, 2.0, 2.0]) / 3
GOAL = Rotation.from_rotvec(THETA * AXIS).as_matrix()
J_STAR = 12 * I ** 2 * THETA ** 2 / T ** 3


def slew(steps, **keywords):
    disc = dmoc.discretize(dmoc.systems.spacecraft((I, I, I)), T / steps)
    problem = dmoc.GroupOptimalControlProblem(disc, steps, R_start=np.eye(3), R_goal=GOAL)
    return dmoc.optimize(problem, **keywords)


def test_slew_reaches_the_eigenaxis_optimum_at_order_two():
    steps = [10, 20, 40]
    results = [slew(N) for N in steps]
    errors = [abs(r.cost - J_STAR) for r in results]
    slope = np.polyfit(np.log(T / np.array(steps)), np.log(errors), 1)[0]
    assert abs(slope - 2.0) < 0.35, (slope, errors)
    best = results[-1]
    assert best.success and best.stats["replay_deviation"] <= 1e-10
    traj = best.trajectory
    assert np.abs(traj.R[-1] - GOAL).max() <= 1e-9 and np.abs(traj.Pi[[0, -1]]).max() <= 1e-12
    rotvec = Rotation.from_matrix(traj.R).as_rotvec()
    assert np.abs(np.cross(rotvec, AXIS)).max() <= 1e-10          # about the fixed axis
    s = traj.t / T
    assert np.abs(rotvec @ AXIS - THETA * (3 * s ** 2 - 2 * s ** 3)).max() <= 1e-2
    assert traj.orthogonality_defect.max() <= 1e-13


def test_slew_problem_refuses_bad_data():
    disc = dmoc.discretize(dmoc.systems.spacecraft((I, I, I)), 0.1)
    with pytest.raises(ValueError, match="R_goal"):
        dmoc.GroupOptimalControlProblem(disc, 10, R_start=np.eye(3), R_goal=2 * np.eye(3))
    with pytest.raises(ValueError, match="controls"):
        dmoc.GroupOptimalControlProblem(dmoc.discretize(dmoc.systems.free_rigid_body(), 0.1), 10,
                                        R_start=np.eye(3), R_goal=GOAL)
    problem = dmoc.GroupOptimalControlProblem(disc, 10, R_start=np.eye(3), R_goal=GOAL)
    with pytest.raises(ValueError, match="expand"):
        dmoc.optimize(problem, expand=True)



class SigintCallback(ca.Callback):
    """An IPOPT iteration callback that sends this process a SIGINT, as a Ctrl-C does."""

    def __init__(self, nx, ng):
        ca.Callback.__init__(self)
        self.sizes = {"x": nx, "g": ng, "lam_x": nx, "lam_g": ng, "f": 1, "lam_p": 0}
        self.construct("sigint", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.sizes[ca.nlpsol_out(i)], 1)

    def eval(self, arg):
        signal.raise_signal(signal.SIGINT)
        return [0]


def test_a_ctrl_c_during_the_group_solve_raises_interrupted_with_the_last_iterate(monkeypatch):
    """A SIGINT while IPOPT iterates (sent from its iteration callback) ends the solve with
    status "interrupted", raised as dmoc.Interrupted (not a SolverError) with throw. The
    solvers are kept per structure: the cache is emptied before, so that the solve builds
    one with the callback, and after, so that no later solve finds it."""
    nlpsol, callbacks = ca.nlpsol, []

    def with_sigint(name, plugin, nlp, options):
        callbacks.append(SigintCallback(nlp["x"].numel(), nlp["g"].numel()))
        return nlpsol(name, plugin, nlp, {**options, "iteration_callback": callbacks[-1]})
    monkeypatch.setattr(ca, "nlpsol", with_sigint)
    dmoc.clear_caches("solvers")
    try:
        with pytest.raises(dmoc.Interrupted) as info:
            slew(10)
    finally:
        dmoc.clear_caches("solvers")
    assert callbacks
    assert (info.value.result.status, info.value.result.success) == ("interrupted", False)
