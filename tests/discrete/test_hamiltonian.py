"""The Hamiltonian side of the seed paper: implicit discrete Hamilton equations (39)/(43)
from the discrete Hamilton-d'Alembert sums (48)/(49). Oracles: the equations written by
hand for symplectic Euler; DOP853 and the knife edge's closed form for the orders; the
Lagrangian trajectory for the discrete Legendre transform; J^T Omega J = Omega."""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc import diagnostics
from dmoc.dirac import dirac_defect
from dmoc.systems import knife_edge, knife_edge_solution

T, INCLINE = 2.0, 0.3
A_INCLINE = 9.81 * np.sin(INCLINE)
ORDERS = {"symplectic-euler": 1, "midpoint": 2}


def pendulum():
    return dmoc.HamiltonianSystem(lambda q, p: 0.5 * p[0] ** 2 - ca.cos(q[0]), 1)


def knife(force=False, a=A_INCLINE):
    """The knife edge on an incline written as H = |p|^2/2 + a x (m = J = 1)."""
    kwargs = dict(force=lambda q, p, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]),
                  n_u=2) if force else {}
    return dmoc.HamiltonianSystem(lambda q, p: ca.dot(p, p) / 2 + a * q[0], 3,
                                  constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
                                  **kwargs)


def pendulum_errors(rule, variant, steps):
    ref = solve_ivp(lambda t, y: [y[1], -np.sin(y[0])], (0, T), [0.5, 1.0], method="DOP853",
                    rtol=1e-13, atol=1e-13).y[:, -1]
    out = []
    for N in steps:
        traj = dmoc.simulate(dmoc.discretize(pendulum(), T / N, rule), q0=[0.5], p0=[1.0],
                             steps=N, variant=variant).trajectory
        out.append(max(abs(traj.q[-1, 0] - ref[0]), abs(traj.p[-1, 0] - ref[1])))
    return out


def knife_errors(rule, variant, steps):
    out = []
    for N in steps:
        disc = dmoc.discretize(knife(), T / N, rule)
        traj = dmoc.simulate(disc, q0=[0, 0, 0], p0=[1, 0, 1], steps=N, variant=variant).trajectory
        exact, _ = knife_edge_solution(traj.t, np.zeros(3), np.array([1.0, 0, 1]), incline=INCLINE)
        out.append(np.abs(traj.q - exact).max())
    return out


def slope(steps, errors):
    return -np.polyfit(np.log(steps), np.log(errors), 1)[0]


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("rule", ORDERS)
def test_declared_orders(rule, variant):
    steps = (20, 40, 80, 160)
    for errors in (pendulum_errors(rule, variant, steps), knife_errors(rule, variant, steps)):
        assert min(errors) > 1e-12
        assert abs(slope(steps, errors) - ORDERS[rule]) < 0.35, errors


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("rule", ORDERS)
def test_constraint_and_dirac_membership_at_every_step(rule, variant):
    disc = dmoc.discretize(knife(force=True), 0.05, rule)
    controls = np.random.default_rng(0).normal(size=(200, 2))
    traj = dmoc.simulate(disc, q0=[0, 0, 0], p0=[1, 0, 1], steps=200, controls=controls,
                         variant=variant).trajectory
    assert diagnostics.constraint_violation(disc, traj).max() < 1e-10
    assert dirac_defect(disc, traj).max() < 1e-10
    assert diagnostics.residual_norms(disc, traj).max() < 1e-10
    # not vacuous: a momentum kick off the range of A(q)^T leaves the structure
    p = traj.p.copy()
    p[100] += 1e-6 * np.array([np.cos(traj.q[100, 2]), np.sin(traj.q[100, 2]), 0.0])
    kicked = dmoc.Trajectory(traj.t, traj.q, p, traj.lam, traj.u, traj.h, traj.variant, traj.mu, traj.s)
    assert dirac_defect(disc, kicked).max() > 5e-7


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("rule", ORDERS)
def test_unconstrained_step_maps_are_symplectic(rule, variant):
    system = dmoc.HamiltonianSystem(lambda q, p: ca.dot(p, p) / 2 + ca.cos(q[0]) * ca.sin(q[1]), 2)
    disc = dmoc.discretize(system, 0.2, rule)
    assert diagnostics.symplecticity_defect(disc, [0.3, 0.1], [0.2, -0.4], variant=variant) < 1e-13


def test_symplectic_euler_rows_are_the_hand_written_equations():
    """(39): q1 = q0 + h H_p(q0, p1), p0 = p1 + h H_q(q0, p1) - h f + A^T lam;
    (43): q1 = q0 + h H_p(q1, p0), p1 = p0 - h H_q(q1, p0) + h f - A^T lam (at q1)."""
    disc, h = dmoc.discretize(knife(force=True), 0.1, "symplectic-euler"), 0.1
    rng = np.random.default_rng(1)

    def A(q):
        return np.array([-np.sin(q[2]), np.cos(q[2]), 0.0])

    def f(q, u):
        return np.array([u[0] * np.cos(q[2]), u[0] * np.sin(q[2]), u[1]])
    grad_q = np.array([A_INCLINE, 0.0, 0.0])
    for _ in range(10):
        q0, p0, q1, p1 = (rng.normal(size=3) for _ in range(4))
        lam, u = rng.normal(size=1), rng.normal(size=2)
        plus = np.array(dmoc.step_residual(disc, "+")(q0, p0, q1, p1, lam, [], u, h)).ravel()
        want = np.r_[p0 - p1 - h * grad_q + h * f(q0, u) - A(q0) * lam, q0 + h * p1 - q1,
                     A((q0 + q1) / 2) @ (q1 - q0) / h]
        np.testing.assert_allclose(plus, want, atol=1e-12)
        minus = np.array(dmoc.step_residual(disc, "-")(q0, p0, q1, p1, lam, [], u, h)).ravel()
        want = np.r_[-q0 + q1 - h * p0, p0 - h * grad_q + h * f(q1, u) - p1 - A(q1) * lam,
                     A((q0 + q1) / 2) @ (q1 - q0) / h]
        np.testing.assert_allclose(minus, want, atol=1e-12)


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("case", ["knife-incline", "unconstrained", "unconstrained-lobatto3"])
def test_discrete_legendre_reproduces_the_lagrangian_trajectory(case, variant):
    if case == "knife-incline":
        system, q0, p0, rule = knife_edge(incline=INCLINE), [0, 0, 0], [1, 0, 1], "midpoint"
    else:
        system = dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) + ca.cos(q[0]) * ca.cos(q[1]), 2)
        q0, p0, rule = [0.3, 0.1], [0.2, -0.4], "lobatto3" if case.endswith("lobatto3") else "trapezoid"
    disc = dmoc.discretize(system, 0.05, rule)
    legendre = dmoc.discrete_legendre(disc)
    a = dmoc.simulate(disc, q0=q0, p0=p0, steps=200, variant=variant).trajectory
    b = dmoc.simulate(legendre, q0=q0, p0=p0, steps=200, variant=variant).trajectory
    assert np.abs(a.q - b.q).max() < 1e-10 and np.abs(a.p - b.p).max() < 1e-10
    assert np.abs(a.q[-1] - a.q[0]).max() > 0.1          # it moved


@pytest.mark.parametrize("variant", ["+", "-"])
def test_dmoc_with_a_hamiltonian_discretization(variant):
    """Knife-edge parking with H = |p|^2/2: the optimum replays, the variants agree, the
    Legendre transform of the midpoint discretization gives the Lagrangian optimum."""
    N = 50
    disc = dmoc.discretize(knife(force=True, a=0.0), 4.0 / N, "midpoint")
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 1, 0], variant=variant)
    result = dmoc.optimize(problem)
    replay_q, replay_p = diagnostics.replay_error(problem, result)
    assert replay_q < 1e-8 and replay_p < 1e-8
    parking = dmoc.problems.knife_edge_parking(N, variant=variant)
    lagrangian = dmoc.optimize(parking)
    assert abs(result.cost - lagrangian.cost) < 1e-8       # the implicit midpoint rule, both ways
    via = dmoc.optimize(dmoc.OptimalControlProblem(dmoc.discrete_legendre(parking.disc), N,
                                                   q_start=[0, 0, 0], q_goal=[0, 1, 0], variant=variant))
    assert abs(via.cost - lagrangian.cost) < 1e-8


def test_bad_hamiltonian_inputs():
    with pytest.raises(ValueError, match="`hamiltonian`"):
        dmoc.HamiltonianSystem(lambda q, p: p, 2)
    with pytest.raises(ValueError, match="`hamiltonian` is required"):
        dmoc.HamiltonianSystem(None, 2)
    disc = dmoc.discretize(pendulum(), 0.1)
    with pytest.raises(ValueError, match="give `p0`"):
        dmoc.simulate(disc, q0=[0.0], v0=[1.0], steps=3)
    with pytest.raises(ValueError, match="`rule` must be one of 'symplectic-euler', 'midpoint'"):
        dmoc.discretize(pendulum(), 0.1, "lobatto3")
    with pytest.raises(ValueError, match="does not belong to this discretization"):
        dmoc.simulate(disc, q0=[0.0], p0=[1.0], steps=3, variant=dmoc.formulations.LagrangianPlus())
    with pytest.raises(ValueError, match="stage-free rule"):
        dmoc.discrete_legendre(dmoc.discretize(knife_edge(), 0.1, "lobatto3"))


@pytest.mark.parametrize("variant", ["+", "-"])
def test_holonomic_hamiltonian_spherical_pendulum(variant):
    """H = abs(p)^2/2 + z with g = abs(q)^2 - 1 kept at every node, the vertical angular
    momentum x p_y - y p_x conserved (Noether: the discretization is rotation invariant)."""
    system = dmoc.HamiltonianSystem(lambda q, p: ca.dot(p, p) / 2 + 9.81 * q[2], 3,
                                    holonomic=lambda q: ca.dot(q, q) - 1)
    disc = dmoc.discretize(system, 0.01, "midpoint")
    q0 = np.array([np.sin(1.0), 0.0, -np.cos(1.0)])
    p0 = np.array([0.0, 1.2, 0.0])                      # tangent: d/dt abs(q)^2 = 0
    traj = dmoc.simulate(disc, q0=q0, p0=p0, steps=2000, variant=variant).trajectory
    assert np.abs(np.sum(traj.q ** 2, axis=1) - 1).max() < 1e-12
    pbar = diagnostics.mean_momenta(disc, traj)
    Lz = traj.q[:-1, 0] * pbar[:, 1] - traj.q[:-1, 1] * pbar[:, 0]
    assert np.abs(Lz - Lz[0]).max() < 1e-12 * max(1.0, abs(Lz[0]))
    assert dirac_defect(disc, traj).max() < 1e-10
