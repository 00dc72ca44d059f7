"""One rule interface (`dmoc.discrete.Rule`) for the Lagrangian rules and the Hamiltonian
rules: declared sizes and flags against the docs' table, the control interpolation of both
families against the Lagrange interpolant written here, and a path-constrained optimum of
the discrete Legendre transform of lobatto3 against the Lagrangian lobatto3 optimum (the
two formulations of one discretization must agree)."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.discrete import HamiltonianRule, Rule

N, T = 20, 2.0
U_MAX, V_MAX = 0.8, 0.6


def lagrange(nodes, values, c):
    """sum_j values[j] prod_{i != j} (c - c_i)/(c_j - c_i)."""
    total = np.zeros_like(values[0])
    for j, cj in enumerate(nodes):
        weight = np.prod([(c - ci) / (cj - ci) for i, ci in enumerate(nodes) if i != j])
        total = total + weight * values[j]
    return total


def forced_pair():
    """Two coupled pendula-like coordinates, a force u on each, no constraints."""
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) + ca.cos(q[0]) * ca.cos(q[1]), 2,
                                 force=lambda q, v, u: ca.vertcat(u[0], u[1]), n_u=2)


class LinearControlEuler(HamiltonianRule):
    """Symplectic Euler with a control linear over the step, its force sampled at 1/4 (+)
    and 3/4 (-) of the step."""

    def __init__(self):
        super().__init__("euler-linear-controls", 1, 0, (0.0, 1.0))

    def right(self, H, q0, p1, s, h):
        return ca.dot(p1, q0) + h * H(q0, p1), [(h, q0, p1, 0.25)]

    def left(self, H, p0, q1, s, h):
        return -ca.dot(p0, q1) + h * H(q1, p0), [(h, q1, p0, 0.75)]


def hamiltonian_pair(force_scale=1.0):
    return dmoc.HamiltonianSystem(lambda q, p: 0.5 * ca.dot(p, p) - ca.cos(q[0]) * ca.cos(q[1]), 2,
                                  force=lambda q, p, u: force_scale * ca.vertcat(u[0], u[1]), n_u=2)


def knife():
    return dmoc.systems.knife_edge(incline=0.2)


# rule -> (stage blocks, stage nodes, interior multipliers, control nodes), from the table
# of docs/stages/discretization.md
DECLARED = {
    "midpoint": ((0, (), False, (0.5,)), lambda: dmoc.discretize(knife(), 0.1, "midpoint")),
    "lobatto3": ((1, (0.5,), True, (0.0, 0.5, 1.0)), lambda: dmoc.discretize(knife(), 0.1, "lobatto3")),
    "hamiltonian-midpoint": ((2, (), False, (0.5,)),
                             lambda: dmoc.discretize(hamiltonian_pair(), 0.1, "midpoint")),
    "legendre-midpoint": ((1, (), False, (0.5,)),
                          lambda: dmoc.discrete_legendre(dmoc.discretize(knife(), 0.1, "midpoint"))),
    "legendre-lobatto3": ((2, (0.5,), False, (0.0, 0.5, 1.0)),
                          lambda: dmoc.discrete_legendre(dmoc.discretize(forced_pair(), 0.1, "lobatto3"))),
}


@pytest.mark.parametrize("name", DECLARED)
def test_both_families_declare_the_same_names(name):
    (blocks, stage_nodes, interior, control_nodes), make = DECLARED[name]
    disc = make()
    rule, sys = disc.rule, disc.system
    assert isinstance(rule, Rule)
    assert (rule.n_stage_blocks, rule.stage_nodes, rule.has_interior_multipliers,
            rule.control_nodes) == (blocks, stage_nodes, interior, control_nodes)
    assert disc.n_stages == blocks * sys.n
    assert disc.n_multipliers == (1 + len(stage_nodes) if interior else 1) * sys.m
    assert disc.n_controls == len(control_nodes) * sys.n_u
    # the stage guess has the declared width, the chord's configurations at the stage nodes last
    q = np.linspace(0.0, 1.0, 4)[:, None] * np.arange(1, sys.n + 1)
    guess = rule.stage_guess(q, q)
    assert guess.shape == (3, disc.n_stages)
    if stage_nodes:
        chord = q[:-1] + stage_nodes[0] * np.diff(q, axis=0)
        np.testing.assert_allclose(guess[:, -sys.n:], chord, rtol=0, atol=1e-15)


@pytest.mark.parametrize("make", [
    lambda: dmoc.discretize(forced_pair(), 0.1, "lobatto3").rule,
    lambda: dmoc.discretize(forced_pair(), 0.1, "lobatto4").rule,
    lambda: dmoc.discrete_legendre(dmoc.discretize(forced_pair(), 0.1, "lobatto3")).rule,
    lambda: dmoc.discrete_legendre(dmoc.discretize(forced_pair(), 0.1, "lobatto4")).rule,
    lambda: dmoc.discretize(hamiltonian_pair(), 0.1, "midpoint").rule,
    lambda: LinearControlEuler(),
], ids=["lobatto3", "lobatto4", "legendre-lobatto3", "legendre-lobatto4", "hamiltonian-midpoint",
        "hamiltonian-linear-controls"])
def test_control_at_is_the_lagrange_interpolant(make):
    rule = make()
    rng = np.random.default_rng(3)
    nodes = rule.control_nodes
    values = [rng.normal(size=2) for _ in nodes]
    u = ca.DM(np.concatenate(values))
    for c in (0.0, 0.13, 0.5, 0.77, 1.0):
        got = np.array(rule.control_at(u, c)).ravel()
        np.testing.assert_allclose(got, lagrange(nodes, values, c), rtol=0, atol=1e-14)
    if len(nodes) > 1:          # not a held control: it varies over the step
        assert np.abs(np.array(rule.control_at(u, 0.0) - rule.control_at(u, 1.0))).max() > 1e-3


def test_hamiltonian_forces_act_with_the_interpolated_control():
    """A Hamiltonian rule's force does virtual work with u at the sample's step time:
    H_d+ = p1 . q0 + h H(q0, p1) gives f_q0 = h f(q0, p1, u(1/4)), H_d- gives f_q1 =
    h f(q1, p0, u(3/4)), u linear between the two control nodes."""
    disc = dmoc.discretize(hamiltonian_pair(force_scale=2.0), 0.1, LinearControlEuler())
    q0, p1, p0, q1 = (np.array(v) for v in ([0.1, 0.2], [0.3, -0.4], [0.5, 0.6], [-0.7, 0.8]))
    u0, u1 = np.array([1.0, -2.0]), np.array([3.0, 5.0])
    u = np.concatenate([u0, u1])
    f_q0, _ = disc.right_force(q0, p1, [], u, 0.1)
    f_q1, _ = disc.left_force(p0, q1, [], u, 0.1)
    np.testing.assert_allclose(np.array(f_q0).ravel(), 0.1 * 2.0 * (0.75 * u0 + 0.25 * u1), atol=1e-15)
    np.testing.assert_allclose(np.array(f_q1).ravel(), 0.1 * 2.0 * (0.25 * u0 + 0.75 * u1), atol=1e-15)


def path(q, v, u):
    """A bound on a control and on a velocity, imposed at every step midpoint."""
    return ca.vertcat(u[0] - U_MAX, v[1] - V_MAX)


def path_rows(traj, h):
    """The two rows of `path` at the midpoints, written from the trajectory: lobatto3's
    control nodes are (0, 1/2, 1), so u(1/2) is the middle node's value (columns 2:4), and
    the quadratic through q_k, s_k, q_{k+1} has the chord's slope at its middle."""
    u_mid = traj.u[:, 2:4]
    v_mid = np.diff(traj.q, axis=0) / h
    return np.column_stack([u_mid[:, 0] - U_MAX, v_mid[:, 1] - V_MAX])


def solve(disc, variant, path_constraints):
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0, 0], q_goal=[1, 1], variant=variant,
                                         path_constraints=path_constraints)
    result = dmoc.optimize(problem, check=False)      # the knots are not where `path` is imposed
    assert result.success, result.message
    return result


@pytest.mark.parametrize("variant", ["+", "-"])
def test_path_constraint_on_the_legendre_transform_of_lobatto3(variant):
    """The path constraint reads the control at the midpoint through the rule's control_at;
    the Legendre transform's optimum is the Lagrangian lobatto3 optimum, and both bounds
    are active there (without them the optimum exceeds both)."""
    lagrangian = dmoc.discretize(forced_pair(), T / N, "lobatto3")
    free = solve(lagrangian, variant, None).trajectory
    assert (path_rows(free, lagrangian.h).max(axis=0) > 0.1).all()
    a = solve(lagrangian, variant, path)
    b = solve(dmoc.discrete_legendre(lagrangian), variant, path)
    assert abs(a.cost - b.cost) < 1e-8 * abs(a.cost)
    assert np.abs(a.trajectory.q - b.trajectory.q).max() < 1e-8
    assert np.abs(a.trajectory.u - b.trajectory.u).max() < 1e-8
    for result in (a, b):
        rows = path_rows(result.trajectory, lagrangian.h)
        assert np.abs(rows.max(axis=0)).max() < 1e-7         # both bounds active, and held
