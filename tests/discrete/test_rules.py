"""A rule is data: its nodes (end points and stage unknowns) and quadrature points define the
interpolant, L_d, f_d and the costs. A rule listed only as numbers, with interior nodes,
must be solved by `simulate` through the stage rows of the one residual and reach its order
on a nonlinear pendulum (oracle: scipy's DOP853 at tight tolerance)."""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc.discrete import Midpoint, QuadratureRule, Trapezoid
from dmoc.discrete.rules import lagrange_basis

SQRT5 = 5 ** 0.5
LOBATTO3 = QuadratureRule("lobatto-3", 4, (0.0, 0.5, 1.0), ((0.0, 1 / 6), (0.5, 2 / 3), (1.0, 1 / 6)))
LOBATTO4 = QuadratureRule("lobatto-4", 6, (0.0, (5 - SQRT5) / 10, (5 + SQRT5) / 10, 1.0),
                          ((0.0, 1 / 12), ((5 - SQRT5) / 10, 5 / 12), ((5 + SQRT5) / 10, 5 / 12),
                           (1.0, 1 / 12)))
Q0, V0, T = 0.5, 1.0, 2.0


def pendulum():
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2 + ca.cos(q[0]), 1)


def reference():
    sol = solve_ivp(lambda t, y: [y[1], -np.sin(y[0])], (0, T), [Q0, V0], method="DOP853",
                    rtol=1e-13, atol=1e-13)
    return sol.y[:, -1]


@pytest.mark.parametrize("rule, steps", [(LOBATTO3, (10, 20, 40, 80)), (LOBATTO4, (5, 10, 20))])
def test_rule_given_as_data_reaches_its_order(rule, steps):
    q_ref, p_ref = reference()
    errors = []
    for N in steps:
        traj = dmoc.simulate(dmoc.discretize(pendulum(), T / N, rule), q0=[Q0], v0=[V0],
                             steps=N).trajectory
        errors.append(max(abs(traj.q[-1, 0] - q_ref), abs(traj.p[-1, 0] - p_ref)))
        assert traj.s.shape == (N, rule.n_stage_blocks)
    slope = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(slope - rule.order) < 0.35, (errors, slope)


def test_stage_values_lie_on_the_interpolant():
    """The stage unknowns are the configurations at the interior nodes: for the 3-node rule
    the stage of each step lies near the midpoint of q_k and q_{k+1} (within O(h^2))."""
    h = 0.01
    traj = dmoc.simulate(dmoc.discretize(pendulum(), h, LOBATTO3), q0=[Q0], v0=[V0],
                         steps=50).trajectory
    mid = (traj.q[:-1, 0] + traj.q[1:, 0]) / 2
    gap = np.abs(traj.s[:, 0] - mid)
    assert gap.max() < h ** 2 and gap.max() > 0


def test_linear_rules_are_the_two_node_case():
    assert (Midpoint().nodes, Trapezoid().nodes) == ((0.0, 1.0), (0.0, 1.0))
    assert Midpoint().n_stage_blocks == Trapezoid().n_stage_blocks == 0
    assert Midpoint() == Midpoint() and Midpoint() != Trapezoid() and hash(Midpoint()) == hash(Midpoint())


@pytest.mark.parametrize("kwargs, match", [
    (dict(nodes=(0.0, 0.7, 0.5, 1.0)), "`nodes`"),
    (dict(nodes=(0.1, 1.0)), "`nodes`"),
    (dict(points=((0.5, 0.9),)), "`points`"),
    (dict(points=()), "`points`"),
])
def test_rule_data_is_validated(kwargs, match):
    with pytest.raises(ValueError, match=match):
        QuadratureRule(**{"name": "x", "order": 2, "nodes": (0.0, 1.0), "points": ((0.5, 1.0),), **kwargs})


def test_lagrange_basis_at_a_number_is_shared_and_exact():
    """The basis at a number c is the closed form l_i(c), l_i'(c) (quadratic on 0, 1/2, 1),
    the same as at an array of that c, and shared read-only between calls."""
    c = 0.3
    value, slope = lagrange_basis((0.0, 0.5, 1.0), c)
    closed = ([2 * (c - 0.5) * (c - 1), -4 * c * (c - 1), 2 * c * (c - 0.5)],
              [4 * c - 3, 4 - 8 * c, 4 * c - 1])
    np.testing.assert_allclose(value, closed[0], rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(slope, closed[1], rtol=1e-15, atol=1e-15)
    array = lagrange_basis(np.array([0.0, 0.5, 1.0]), np.array([c]))
    assert np.array_equal(array[0][0], value) and np.array_equal(array[1][0], slope)
    again = lagrange_basis([0, 0.5, 1], c)
    assert again[0] is value and not value.flags.writeable
