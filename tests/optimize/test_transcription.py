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
