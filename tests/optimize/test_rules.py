"""DMOC with each quadrature rule on a system where the rules differ (a knife edge in a
nonlinear well): the optimum replays exactly through the simulator with the same rule, the
cost converges at the rule's order, and the two rules converge to the same optimum."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.diagnostics import replay_error


def _well_knife_edge():
    """Knife edge (m = J = 1) in the well V = x^2/2 + y^2 + x^4/4, controls as the knife edge."""
    def lagrangian(q, v):
        return 0.5 * ca.dot(v, v) - (q[0] ** 2 / 2 + q[1] ** 2 + q[0] ** 4 / 4)
    return dmoc.MechanicalSystem(
        lagrangian, 3, constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
        force=lambda q, v, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]), n_u=2)


SYSTEM = _well_knife_edge()


def _solve(rule, N, variant="+"):
    disc = dmoc.discretize(SYSTEM, 3.0 / N, rule)
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0.5, 0, 0], q_goal=[0, 0.5, 0],
                                         variant=variant)
    return problem, dmoc.optimize(problem)


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
def test_optimum_replays_with_the_same_rule(rule, variant):
    problem, result = _solve(rule, 60, variant)
    assert max(replay_error(problem, result)) < 1e-8


@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
def test_cost_converges_at_the_rule_order(rule):
    costs = [_solve(rule, N)[1].cost for N in (30, 60, 120, 240)]
    d = np.diff(costs)
    orders = np.log2(d[:-1] / d[1:])
    order = dmoc.discretize(SYSTEM, 0.1, rule).rule.order
    assert np.all(np.abs(orders - order) < 0.35), orders


def test_rules_differ_here_but_share_the_limit():
    midpoint = [_solve("midpoint", N)[1].cost for N in (120, 240)]
    trapezoid = [_solve("trapezoid", N)[1].cost for N in (120, 240)]
    assert abs(midpoint[0] - trapezoid[0]) > 1e-6              # different schemes
    # Richardson-extrapolated limits agree far better than either raw value does.
    limits = [c[1] + (c[1] - c[0]) / 3 for c in (midpoint, trapezoid)]
    assert abs(limits[0] - limits[1]) < 0.05 * abs(midpoint[1] - trapezoid[1])
