"""Control bounds hold between the control nodes: the rules with three or more control
nodes (lobatto3, lobatto4) interpolate each step's controls by a polynomial
(`Trajectory.control`), which the NLP keeps in the box through its Bernstein coefficients
(`dmoc.optimal_control.nlp.control_hull`).

Oracles: the Bernstein coefficients of a polynomial from its power-basis coefficients,
b_i = sum_{j <= i} C(i, j) / C(d, j) a_j (a closed form, not the module's solve); the bounds
themselves, read at 100 points per step of `Trajectory.control`; the closed-form minimum
time of a rest-to-rest slide along the blade under |F| <= a, T* = 2 sqrt(m D / a).
"""

import math

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.optimal_control.nlp.control_hull import hull_matrix

RULES = ("midpoint", "lobatto3", "lobatto4")


@pytest.mark.parametrize("rule", ["lobatto3", "lobatto4"])
def test_hull_matrix_gives_the_bernstein_coefficients(rule):
    nodes = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule).rule.control_nodes
    d = len(nodes) - 1
    a = np.random.default_rng(3).normal(size=d + 1)                  # p(c) = sum a_j c^j
    values = np.polynomial.polynomial.polyval(np.asarray(nodes), a)
    b = [sum(math.comb(i, j) / math.comb(d, j) * a[j] for j in range(i + 1)) for i in range(d + 1)]
    np.testing.assert_allclose(hull_matrix(nodes) @ values, b[1:d], rtol=0, atol=1e-13)
    assert hull_matrix([0.5]).shape == (0, 1) and hull_matrix([0.0, 1.0]).shape == (0, 2)


def _parking(rule, N=20, bound=None):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / N, rule)
    return dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 1, 0], control_bounds=bound)


def _disk(rule, N=16, bound=None):
    disc = dmoc.discretize(dmoc.systems.rolling_disk(), 4.0 / N, rule)
    return dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0, 0], q_goal=[1.0, 0.5, None, 0.8],
                                      control_bounds=bound)


@pytest.mark.parametrize("make", [_parking, _disk], ids=["knife edge", "rolling disk"])
@pytest.mark.parametrize("rule", RULES)
def test_control_bounds_hold_at_100_points_per_step(make, rule):
    """Bounds at 80 % of the free optimum's largest node values: some node on a bound, and
    the interpolant within the box at 100 points of every step, to IPOPT's tolerance
    (without the hull rows lobatto3 reached 0.943 against 0.8 on the parking)."""
    free = dmoc.optimize(make(rule)).trajectory
    upper = 0.8 * np.abs(free.u.reshape(free.steps, -1, free.u.shape[1] // len(free.control_nodes))).max(axis=(0, 1))
    problem = make(rule, bound=(-upper, upper))
    traj = dmoc.optimize(problem).trajectory
    t = np.linspace(traj.t[0], traj.t[-1], 100 * traj.steps + 1)
    u = traj.control(t)
    assert np.isclose(np.abs(traj.u.reshape(traj.steps, -1, upper.size)), upper, atol=1e-7).any()
    assert (u <= upper + 1e-8).all() and (u >= -upper - 1e-8).all()


@pytest.mark.parametrize("rule", RULES)
def test_a_bang_bang_minimum_time_is_never_below_its_closed_form(rule):
    """Slide the knife edge (m = 2) along its blade by D = 1.5 from rest to rest, |F| <= 0.8,
    free final time: T* = 2 sqrt(m D / a); the discrete optimum, whose force interpolant is
    held in the box between the nodes, is not faster (and within 1 % of it at N = 20)."""
    m, D, a, N = 2.0, 1.5, 0.8, 20
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=m), 0.2, rule)
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[D, 0, 0],
                                         duration=(1.0, 10.0), control_bounds=([-a, -1.0], [a, 1.0]),
                                         running_cost=lambda q, v, u: 1 + 1e-6 * ca.sumsqr(u))
    result = dmoc.optimize(problem, check=False)
    T, T_star = result.trajectory.t[-1], 2 * math.sqrt(m * D / a)
    assert T >= T_star * (1 - 1e-7)
    assert T <= T_star * 1.01


def test_a_hull_row_is_named_by_its_control_and_step():
    from dmoc.optimal_control.solver.violation import described
    problem = _parking("lobatto4", N=4, bound=([-np.inf, -1.0], [np.inf, 1.0]))
    T = problem.transcription
    assert T.hulled_controls == (1,)
    first = T.g_layout.slice("control_hull").start
    assert described(T, first + 2 + 1) == "control bound of u[1] between the nodes of step 1 (Bernstein coefficient 2)"
    assert _parking("midpoint", N=4, bound=([-1.0, -1.0], [1.0, 1.0])).transcription.g_layout.numel("control_hull") == 0
