"""The NLP the transcription writes: the running cost is sampled at the rule's quadrature
points, and a free start velocity is kept in the allowed set A(q_0) v_0 = 0.

Oracles, none taken from dmoc's own code: the running cost of the midpoint and trapezoid
rules written out by hand, evaluated at a random NLP vector; A(q) = (-sin theta, cos theta,
0) of the knife edge written by hand."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.systems import knife_edge


H, N = 0.1, 6


def cost(q, v, u):
    """A running cost that depends on q, v and u, so that where it is sampled matters."""
    return q[0] ** 2 + 3.0 * q[1] * v[2] + v[0] ** 2 + ca.sumsqr(u)


def cost_by_hand(rule, q, u):
    """sum_k of the rule's quadrature of `cost` on step k: midpoint at (q_k + q_{k+1})/2,
    trapezoid the mean of the ends, v = (q_{k+1} - q_k)/h on the step, u held."""
    total = 0.0
    for k in range(N):
        v = (q[k + 1] - q[k]) / H
        at = {"midpoint": [(1.0, (q[k] + q[k + 1]) / 2)],
              "trapezoid": [(0.5, q[k]), (0.5, q[k + 1])]}[rule]
        total += sum(w * H * (x[0] ** 2 + 3.0 * x[1] * v[2] + v[0] ** 2 + u[k] @ u[k])
                     for w, x in at)
    return total


@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
def test_running_cost_is_sampled_at_the_rules_points(rule):
    """Mutation: the running cost sampled at (q_k, (q_{k+1} - q_k)/h) instead of the rule's
    quadrature points."""
    problem = dmoc.OptimalControlProblem(dmoc.discretize(knife_edge(), H, rule), N,
                                         q_start=[0, 0, 0], q_goal=[0, 1, 0], running_cost=cost)
    x = np.random.default_rng(3).normal(size=problem.x_layout.size)
    f = float(ca.Function("f", [problem.nlp["x"], problem.nlp["p"]], [problem.nlp["f"]])(x, problem.p))
    q, u = problem.x_layout.unpack(x, "q").T, problem.x_layout.unpack(x, "u").T
    assert f == pytest.approx(cost_by_hand(rule, q, u), rel=1e-13)


@pytest.mark.parametrize("variant", ["+", "-"])
def test_free_start_velocity_is_kept_in_the_allowed_set(variant):
    """Mutation: the rows A(q_0) v_0 = 0 on a free start velocity dropped from the NLP."""
    problem = dmoc.OptimalControlProblem(dmoc.discretize(knife_edge(), H), N,
                                         q_start=[0, 0, None], q_goal=[0, 1, 0],
                                         v_start=[None, None, None], variant=variant)
    x = np.random.default_rng(4).normal(size=problem.x_layout.size)
    g = np.array(ca.Function("g", [problem.nlp["x"], problem.nlp["p"]], [problem.nlp["g"]])(x, problem.p)).ravel()
    theta = problem.x_layout.unpack(x, "q")[2, 0]
    v = problem.x_layout.unpack(x, "v_start")[:, 0]
    rows = g[problem.g_layout.slice("start_velocity")]
    np.testing.assert_allclose(rows, [-np.sin(theta) * v[0] + np.cos(theta) * v[1]], rtol=1e-14)
    assert problem.lbg[problem.g_layout.slice("start_velocity")].tolist() == [0.0]
    assert problem.ubg[problem.g_layout.slice("start_velocity")].tolist() == [0.0]
    # And the optimum honours it.
    result = dmoc.optimize(problem)
    v_opt = problem.x_layout.unpack(result.x, "v_start")[:, 0]
    theta0 = result.trajectory.q[0, 2]
    assert abs(-np.sin(theta0) * v_opt[0] + np.cos(theta0) * v_opt[1]) < 1e-9


@pytest.mark.parametrize("restate", [False, True])
def test_bounds_fix_the_given_data_and_bound_the_rest(restate):
    """lbx and ubx written out block by block from the statement: q_0 and the given
    entries of q_N fixed (x holds q - q_ref), the other knots within the state bounds, u
    within the control bounds at every control node, v_start fixed at 0 for a start
    momentum, v_goal fixed, every other block free; the same after `with_boundary`
    (which shares the bounds of u, h and g and writes the boundary blocks anew)."""
    disc = dmoc.discretize(knife_edge(), H, rule="lobatto3")
    lower, upper = np.array([-0.5, -0.6, -np.inf]), np.array([0.5, 1.5, np.inf])
    q_start, q_goal, v_goal = np.array([0.1, 0.2, 0.3]), np.array([0.0, 1.0, np.nan]), np.zeros(3)
    problem = dmoc.OptimalControlProblem(
        disc, N, q_start=q_start, q_goal=[0.0, 1.0, None], p_start=[1, 2, 3],
        control_bounds=([-2, None], [2, 3]), state_bounds=([-0.5, -0.6, None], [0.5, 1.5, None]))
    if restate:
        q_start, q_goal = np.array([0.2, -0.1, 0.0]), np.array([0.3, 1.1, np.nan])
        problem = problem.with_boundary(q_start=q_start, q_goal=[0.3, 1.1, None], p_start=[0, 1, 0])
    lay, q_ref, nodes = problem.x_layout, q_start, len(disc.rule.control_nodes)
    np.testing.assert_array_equal(problem.q_ref, q_ref)
    for bound, side, data_side in ((problem.lbx, lower, -np.inf), (problem.ubx, upper, np.inf)):
        q = lay.unpack(bound, "q")
        np.testing.assert_array_equal(q[:, 1:N], np.repeat((side - q_ref)[:, None], N - 1, axis=1))
        np.testing.assert_array_equal(q[:, 0], q_start - q_ref)
        np.testing.assert_array_equal(q[:, N], np.where(np.isnan(q_goal), side - q_ref, q_goal - q_ref))
        u = lay.unpack(bound, "u")
        control = [-2.0, -np.inf] if data_side < 0 else [2.0, 3.0]
        np.testing.assert_array_equal(u, np.repeat(np.array(control * nodes)[:, None], N, axis=1))
        np.testing.assert_array_equal(lay.unpack(bound, "v_start")[:, 0], np.zeros(3))
        np.testing.assert_array_equal(lay.unpack(bound, "v_goal")[:, 0], v_goal)
        for name in ("p", "lam", "s", "mu", "nu"):
            assert (lay.unpack(bound, name) == data_side).all(), name
    assert nodes == 3 and lay.numel("h") == 0
