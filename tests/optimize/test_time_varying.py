"""Costs that vary along the horizon: parameters given per step or per knot, and the clock.

Oracles: (1) a linear-quadratic tracking problem on a double integrator, its discrete
flow and its cost (midpoint quadrature, a reference linear in time between knots, a
weight growing with the time) written out in this file and its optimum found by a linear
least-squares solve; (2) a knife edge tracking a reference that is itself a simulated
motion under controls chosen here: the optimum is that motion and those controls, at zero
cost, for each of two references solved on one NLP.
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.errors import InputError

M, H, N, T0, RHO = 2.0, 0.1, 12, 0.3, 0.05


def particle():
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * M * v[0] ** 2, 1, force=lambda q, v, u: u[0], n_u=1)


def tracking_problem(r, ubar, *, q0=0.2, v0=-0.5, rule="midpoint"):
    """min sum_k h [(1 + t)(q - r(t))^2 + RHO (u - ubar_k)^2] at the quadrature points,
    plus (1 + t_N)(q_N - r_N)^2, from (q0, v0), the end free."""
    return dmoc.OptimalControlProblem(
        dmoc.discretize(particle(), H, rule), N, q_start=[q0], v_start=[v0], q_goal=[None],
        v_goal=[None], parameters={"r": r, "ubar": ubar, "t": T0},
        running_cost=lambda q, v, u, w: (1 + w["t"]) * (q[0] - w["r"]) ** 2 + RHO * (u[0] - w["ubar"]) ** 2,
        terminal_cost=lambda q, v, w: (1 + w["t"]) * (q[0] - w["r"]) ** 2)


def least_squares_optimum(r, ubar, q0=0.2, v0=-0.5):
    """The optimum of `tracking_problem` (midpoint rule), written out: the (+) midpoint step
    of L = M v^2 / 2 with the force u, q_{k+1} = q_k + h/M (p_k + h/2 u_k), p_{k+1} = p_k +
    h u_k, is linear, so q_k = c_k + G_k u, and the cost is a sum of weighted squares of
    affine functions of u."""
    c, G = [np.array([q0, M * v0])], [np.zeros((2, N))]
    A, B = np.array([[1, H / M], [0, 1]]), np.array([H * H / (2 * M), H])
    for k in range(N):
        c.append(A @ c[-1])
        G.append(A @ G[-1])
        G[-1][:, k] += B
    rows, rhs = [], []
    for k in range(N):              # the midpoint: q_{k+1/2}, r at t_k + h/2, time t_k + h/2
        weight = np.sqrt(H * (1 + T0 + (k + 0.5) * H))
        rows.append(weight * (G[k][0] + G[k + 1][0]) / 2)
        rhs.append(weight * ((r[k, 0] + r[k + 1, 0]) / 2 - (c[k][0] + c[k + 1][0]) / 2))
        rows.append(np.sqrt(H * RHO) * np.eye(N)[k])
        rhs.append(np.sqrt(H * RHO) * ubar[k, 0])
    weight = np.sqrt(1 + T0 + N * H)
    rows.append(weight * G[N][0])
    rhs.append(weight * (r[N, 0] - c[N][0]))
    u = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    q = np.array([ck[0] + Gk[0] @ u for ck, Gk in zip(c, G)])
    return q, u


def reference(seed):
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(0, 0.1, (N + 1, 1)), axis=0), rng.normal(0, 1, (N, 1))


def test_linear_quadratic_tracking_equals_the_least_squares_optimum():
    r, ubar = reference(0)
    problem = tracking_problem(r, ubar)
    result = dmoc.optimize(problem)
    q, u = least_squares_optimum(r, ubar)
    np.testing.assert_allclose(result.trajectory.q[:, 0], q, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.trajectory.u[:, 0], u, rtol=0, atol=1e-7)
    # new values along the horizon: the same NLP, and the optimum of the new data
    r2, ubar2 = reference(1)
    moved = problem.with_parameters(r=r2, ubar=ubar2, t=T0)
    assert moved.structure == problem.structure
    again = dmoc.optimize(moved)
    assert again.stats["solver_reused"]
    q2, u2 = least_squares_optimum(r2, ubar2)
    np.testing.assert_allclose(again.trajectory.q[:, 0], q2, rtol=0, atol=1e-8)
    np.testing.assert_allclose(again.trajectory.u[:, 0], u2, rtol=0, atol=1e-7)


def test_the_clock_and_the_knots_are_read_where_the_cost_is_evaluated():
    """The time and the reference at the points of the rule: moving t_0 changes the optimum
    as the oracle's weights say, and a reference given per step (held) is not the one given
    per knot (linear in time)."""
    r, ubar = reference(2)
    problem = tracking_problem(r, ubar)
    later = dmoc.optimize(problem.with_parameters(t=T0 + 5.0))
    q, _ = least_squares_optimum(r, ubar)
    assert np.abs(later.trajectory.q[:, 0] - q).max() > 1e-4          # the weights moved
    held = dmoc.optimize(tracking_problem(r[:N], ubar))                 # r_k on all of step k
    assert np.abs(held.trajectory.q[:, 0] - q).max() > 1e-4


def knife_reference(u_ref, v0):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    run = dmoc.simulate(disc, q0=[0.1, -0.2, 0.3], v0=v0, steps=N, controls=u_ref)
    return disc, run.trajectory


def test_a_knife_edge_tracking_a_simulated_motion_finds_that_motion():
    """Tracking a reference that is a discrete motion of the model under controls u_ref:
    the optimum is that motion (zero cost), on the same NLP for a second reference."""
    k = np.arange(N)[:, None]
    u_ref = np.hstack([np.sin(0.5 * k), 0.5 * np.cos(0.3 * k)])
    v0 = [np.cos(0.3), np.sin(0.3), 0.2]
    disc, ref = knife_reference(u_ref, v0)
    problem = dmoc.OptimalControlProblem(
        disc, N, q_start=ref.q[0], v_start=v0, q_goal=[None] * 3, v_goal=[None] * 3,
        parameters={"q_ref": ref.q, "u_ref": ref.u},
        running_cost=lambda q, v, u, w: ca.sumsqr(q - w["q_ref"]) + ca.sumsqr(u - w["u_ref"]))
    result = dmoc.optimize(problem)
    np.testing.assert_allclose(result.trajectory.q, ref.q, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.trajectory.u, ref.u, rtol=0, atol=1e-7)
    assert result.cost < 1e-14
    _, other = knife_reference(-u_ref, v0)
    again = dmoc.optimize(problem.with_parameters(q_ref=other.q, u_ref=other.u))
    assert again.stats["solver_reused"]
    np.testing.assert_allclose(again.trajectory.q, other.q, rtol=0, atol=1e-8)


def test_path_constraints_read_a_moving_bound_at_every_knot():
    """q(t) >= b_k with b per knot: the knots' rows read b_k, so a bound rising through
    the motion holds at every knot (the oracle: the bound itself)."""
    b = np.linspace(0.0, 1.0, N + 1)[:, None]
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(particle(), H), N, q_start=[0.0], q_goal=[None], v_goal=[None],
        parameters={"b": b}, path_constraints=lambda q, v, u, w: w["b"] - q[0])
    q = dmoc.optimize(problem).trajectory.q[:, 0]
    assert (q >= b[:, 0] - 1e-7).all() and np.abs(q - b[:, 0]).min() < 1e-6


@pytest.mark.parametrize("value, match", [
    (np.zeros((5, 1)), r"parameters\['r'\].*\(12, k\).*\(13, k\).*got shape \(5, 1\)"),
    (np.zeros((N, 1, 1)), r"parameters\['r'\]"),
    (np.full((N, 1), np.nan), r"parameters\['r'\]` must be finite; entry \(0, 0\)"),
])
def test_bad_values_along_the_horizon_name_the_parameter(value, match):
    with pytest.raises(InputError, match=match):
        tracking_problem(value, np.zeros((N, 1)))


def test_new_values_keep_their_shapes_and_the_clock_is_a_scalar():
    r, ubar = reference(0)
    problem = tracking_problem(r, ubar)
    with pytest.raises(InputError, match=r"parameters\['r'\]` must be shape \(13, 1\); got shape \(12, 1\)"):
        problem.with_parameters(r=r[:N])
    with pytest.raises(InputError, match=r"parameters\['t'\]` must be a scalar"):
        tracking_problem(r, ubar).with_parameters(t=[0.0, 1.0])
    with pytest.raises(InputError, match=r"with_steps.*'r', 'ubar'"):
        problem.with_steps(2 * N)


def test_the_clock_of_a_free_final_time_runs_with_its_step():
    """Rest-to-rest parking costs less the longer it takes, so T reaches its upper bound
    10; the clock t_0 + k h with t_0 = 0.5, held below 5 at every knot, stops it at 4.5."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.2)
    free = dict(q_start=[0, 0, 0], q_goal=[0, 1, 0], duration=(1.0, 10.0))
    unbounded = dmoc.optimize(dmoc.OptimalControlProblem(disc, 20, **free))
    clocked = dmoc.optimize(dmoc.OptimalControlProblem(
        disc, 20, **free, parameters={"t": 0.5}, path_constraints=lambda q, v, u, w: w["t"] - 5.0))
    assert unbounded.trajectory.t[-1] == pytest.approx(10.0, abs=1e-8)
    assert clocked.trajectory.t[-1] == pytest.approx(4.5, abs=1e-8)
