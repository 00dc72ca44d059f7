"""Tests that catch plausible bugs no other test catches (issue 16, mutation study).

Each test is written against one mutation of the core, named in its docstring; the
mutation was applied to a copy of the package and this test failed under it
(docs/verification.md, "Mutations"). Oracles, none taken from dmoc's own code:
- the running cost of the midpoint and trapezoid rules written out by hand, evaluated at
  a random NLP vector;
- A(q) = (-sin theta, cos theta, 0) of the knife edge written by hand;
- a replayed optimum whose stored momenta are perturbed by a known amount at one interior
  knot;
- IPOPT's and dmoc's own option checks (not Python's keyword check).
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import batch, diagnostics
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


@pytest.fixture(scope="module")
def parking():
    problem = dmoc.OptimalControlProblem(dmoc.discretize(knife_edge(), 0.2), 20,
                                         q_start=[0, 0, 0], q_goal=[0, 1, 0])
    return problem, dmoc.optimize(problem)


@pytest.mark.parametrize("block, knot", [("p", 7), ("p", 13), ("q", 9)])
def test_replay_error_sees_every_knot(parking, block, knot):
    """Mutation: `replay_error` comparing only p_0 (or only q_0) with the replay."""
    problem, result = parking
    assert max(diagnostics.replay_error(problem, result)) < 1e-9
    kicked = dmoc.OptimizationResult(**{**vars(result)})
    traj = result.trajectory
    data = {f: getattr(traj, f) for f in ("t", "q", "p", "lam", "u", "h", "variant", "mu", "s",
                                          "control_nodes")}
    data[block] = data[block].copy()
    data[block][knot, 1] += 1e-3
    kicked.trajectory = dmoc.Trajectory(**data)
    errors = dict(zip("qp", diagnostics.replay_error(problem, kicked)))
    assert errors[block] == pytest.approx(1e-3, rel=1e-6)


def test_unknown_options_are_rejected_by_dmoc(capfd):
    """In place of a test of Python's keyword check: dmoc's own checks reject an unknown
    key of a batch run and an option IPOPT does not know, naming it."""
    disc = dmoc.discretize(knife_edge(), H)
    with pytest.raises(dmoc.InputError, match=r"`runs\[0\]` has unknown keys \['tolerance'\]"):
        batch.simulate_many(disc, [{"q0": [0, 0, 0], "v0": [1, 0, 0], "steps": 2,
                                    "tolerance": 1e-9}], client="tcp://127.0.0.1:1")
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(ValueError, match=r"(?s)`options`.*No such IPOPT option: tolerance"):
        dmoc.optimize(problem, options={"tolerance": 1e-9})
    capfd.readouterr()
