"""DMOC with inequality constraints, soft goals and free end data: bounds and path
constraints hold at the optimum and are active where they cut the unconstrained optimum;
a terminal penalty composes with the hard-goal problem as the scaling law of a quadratic
cost predicts; free goal velocities satisfy the constraint and the transversality
condition u_{N-1} -> 0 of a free end."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.diagnostics import replay_error
from dmoc.problems import knife_edge_parking

N = 50


@pytest.fixture(scope="module")
def free():
    problem = knife_edge_parking(N)
    return problem, dmoc.optimize(problem)


def _parking(**kwargs):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / N)
    return dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 1, 0], **kwargs)


def _check_replay(problem, result):
    assert max(replay_error(problem, result)) < 1e-8


def test_active_control_bounds(free):
    _, unconstrained = free
    bound = 0.7 * np.abs(unconstrained.trajectory.u).max()
    problem = _parking(control_bounds=([-bound, -bound], [bound, bound]))
    result = dmoc.optimize(problem)
    u = result.trajectory.u
    assert np.abs(u).max() <= bound                       # exactly, bounds are honoured
    assert np.isclose(np.abs(u).max(), bound, rtol=0, atol=1e-8)   # and active
    assert result.cost > unconstrained.cost + 1e-3
    _check_replay(problem, result)


def test_state_bounds_cut_the_path(free):
    _, unconstrained = free
    assert unconstrained.trajectory.q[:, 0].min() < -0.15   # the free path swings to x ~ -0.19
    problem = _parking(state_bounds=([-0.1, None, None], [0.1, None, None]))
    result = dmoc.optimize(problem)
    x = result.trajectory.q[:, 0]
    assert x.min() >= -0.1 and x.max() <= 0.1
    assert np.isclose(x.min(), -0.1, atol=1e-8) and np.isclose(x.max(), 0.1, atol=1e-8)
    assert result.cost > unconstrained.cost
    _check_replay(problem, result)


def test_path_constraint_at_step_midpoints_and_knots(free):
    _, unconstrained = free
    limit = 0.5 * np.abs(unconstrained.trajectory.q[:, 2]).max()
    problem = _parking(path_constraints=lambda q, v, u: ca.vertcat(q[2] - limit, -q[2] - limit))
    result = dmoc.optimize(problem, check=False)
    q = result.trajectory.q
    theta_mid = (q[:-1, 2] + q[1:, 2]) / 2               # path constraints act at step midpoints
    theta = np.concatenate([theta_mid, q[:, 2]])         # and at every knot
    assert np.abs(theta).max() <= limit + 1e-9
    assert np.isclose(np.abs(theta).max(), limit, atol=1e-8)
    assert result.cost > unconstrained.cost
    _check_replay(problem, result)


@pytest.mark.parametrize("weight", [1.0, 30.0])
def test_terminal_penalty_scales_the_hard_goal_optimum(weight):
    """Turning in place is linear-quadratic: the optimal cost of reaching theta_N = d at
    rest is c d^2, so with theta_N free and a penalty w (theta_N - Theta)^2 the optimum is
    d* = w Theta / (c + w) with total cost c w Theta^2 / (c + w)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 2.0 / N)
    Theta = 1.5
    hard = dmoc.optimize(dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 0, 1.0]))
    c = hard.cost
    soft = dmoc.optimize(dmoc.OptimalControlProblem(
        disc, N, q_start=[0, 0, 0], q_goal=[0, 0, None],
        terminal_cost=lambda q, v: weight * (q[2] - Theta) ** 2))
    d = weight * Theta / (c + weight)
    assert soft.trajectory.q[-1, 2] == pytest.approx(d, rel=1e-9)
    assert soft.cost == pytest.approx(c * weight * Theta**2 / (c + weight), rel=1e-9)


def test_free_goal_velocity():
    """Arrive at (0, 1, 0) with the velocity along the blade free: the final velocity lies in
    Delta_Q(q_N), the replay matches, the effort is no higher than rest to rest, and the
    force along the blade obeys transversality: u0(T) = 0, so u0 on the last step is O(h)."""
    problem = _parking(v_goal=[None, None, 0.0])
    result = dmoc.optimize(problem)
    finer = dmoc.optimize(dmoc.OptimalControlProblem(
        dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / (2 * N)), 2 * N,
        q_start=[0, 0, 0], q_goal=[0, 1, 0], v_goal=[None, None, 0.0]))
    last, last_finer = abs(result.trajectory.u[-1, 0]), abs(finer.trajectory.u[-1, 0])
    assert last < 0.1 * np.abs(result.trajectory.u[:, 0]).max()
    assert last / last_finer == pytest.approx(2.0, abs=0.1)
    traj = result.trajectory
    v_N = problem.x_layout.unpack(result.x, "v_goal")[:, 0]
    A = np.array(problem.disc.system.constraint_matrix(traj.q[-1]))
    assert np.abs(A @ v_N).max() < 1e-10
    assert result.cost <= dmoc.optimize(knife_edge_parking(N)).cost
    _check_replay(problem, result)
