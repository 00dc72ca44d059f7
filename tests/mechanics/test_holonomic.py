"""Holonomic constraints g(q) = 0 (`MechanicalSystem(holonomic=g)`), kept exactly at every node.

Oracles, none taken from the code under test:
- the index-1 equations M q'' = -grad V + A^T lam, A q'' = -(d/dt A) q' (the constraints
  differentiated to acceleration level, A the one-forms), written out by hand below for a
  bead on a cubic curve and for a knife edge on a quartic surface, solved by DOP853
  (rtol = atol = 1e-13);
- g, its Jacobian, the energy and the spherical pendulum's vertical angular momentum
  written out by hand below;
- the (+) step equations (SHAKE form) written by hand for the midpoint rule;
- a bead whose constraint is given only as its one-form dg, which must drift off g = 0.
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc.dirac import dirac_defect

GRAV, K4 = 9.81, 2.0             # bead: gravity and a quartic spring, V = GRAV y + K4 x^4 / 4
X0 = 0.3                          # bead start on y = x^3 - x, moving along the curve
BEAD_Q0 = np.array([X0, X0 ** 3 - X0])
BEAD_V0 = 0.5 * np.array([1.0, 3 * X0 ** 2 - 1])
A2, A4, KM, KJ = 0.8, 0.6, 1.3, 0.7      # surface z = A2 x^2/2 + A4 x^4/4; blade mass, inertia
KY = 1.5                                  # a spring K_y y^2/2 on the blade (rules then differ)
RULES = ("midpoint", "trapezoid")
VARIANTS = ("+", "-")
EPS = np.finfo(float).eps


def bead_g(q):
    """The cubic curve, by hand: g = y - (x^3 - x)."""
    return q[..., 1] - (q[..., 0] ** 3 - q[..., 0])


def bead_energy(q, v):
    return 0.5 * np.sum(v ** 2, axis=-1) + GRAV * q[..., 1] + K4 / 4 * q[..., 0] ** 4


def bead(*, one_form=False):
    """The bead as a holonomic system, or with its constraint given only as dg."""
    def lagrangian(q, v):
        return 0.5 * ca.dot(v, v) - GRAV * q[1] - K4 / 4 * q[0] ** 4
    if one_form:
        return dmoc.MechanicalSystem(lagrangian, 2, constraints=lambda q: ca.horzcat(1 - 3 * q[0] ** 2, 1))
    return dmoc.MechanicalSystem(lagrangian, 2, holonomic=lambda q: q[1] - (q[0] ** 3 - q[0]))


def bead_rhs(t, z):
    """Index-1 bead: q'' = -grad V + G^T lam with G = dg/dq = (1 - 3x^2, 1) and
    G q'' - 6 x x'^2 = 0 (g differentiated twice)."""
    x, y, vx, vy = z
    G = np.array([1 - 3 * x ** 2, 1.0])
    grad_V = np.array([K4 * x ** 3, GRAV])
    lam = (G @ grad_V + 6 * x * vx ** 2) / (G @ G)
    acc = -grad_V + G * lam
    return [vx, vy, acc[0], acc[1]]


def surface_blade():
    """A knife edge on the surface z = A2 x^2/2 + A4 x^4/4 under gravity and a spring in y:
    q = (x, y, theta, z), one nonholonomic one-form (no sideways slip), one holonomic
    constraint."""
    def lagrangian(q, v):
        return (KM / 2 * (v[0] ** 2 + v[1] ** 2 + v[3] ** 2) + KJ / 2 * v[2] ** 2
                - KM * GRAV * q[3] - KY / 2 * q[1] ** 2)
    return dmoc.MechanicalSystem(
        lagrangian, 4, constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0, 0),
        holonomic=lambda q: q[3] - (A2 / 2 * q[0] ** 2 + A4 / 4 * q[0] ** 4))


def surface_one_forms(q):
    """(2, 4) one-forms by hand: no slip, then dg of g = z - A2 x^2/2 - A4 x^4/4."""
    x, theta = q[0], q[2]
    return np.array([[-np.sin(theta), np.cos(theta), 0, 0], [-(A2 * x + A4 * x ** 3), 0, 0, 1]])


def surface_rhs(t, z):
    """Index-1 blade: KKT solve of M q'' - A^T lam = -grad V, A q'' = -(dA/dt) q',
    V = KM GRAV z + KY y^2/2."""
    q, v = z[:4], z[4:]
    x, theta = q[0], q[2]
    A = surface_one_forms(q)
    dA_v = np.array([-v[2] * (np.cos(theta) * v[0] + np.sin(theta) * v[1]),
                     -(A2 + 3 * A4 * x ** 2) * v[0] ** 2])
    M = np.diag([KM, KM, KJ, KM])
    kkt = np.block([[M, -A.T], [A, np.zeros((2, 2))]])
    sol = np.linalg.solve(kkt, np.r_[[0, -KY * q[1], 0, -KM * GRAV], -dA_v])
    return np.r_[v, sol[:4]]


SURFACE_Q0 = np.array([0.4, -0.1, 0.3, A2 / 2 * 0.4 ** 2 + A4 / 4 * 0.4 ** 4])
SURFACE_V0 = np.array([np.cos(0.3), np.sin(0.3), 0.9, (A2 * 0.4 + A4 * 0.4 ** 3) * np.cos(0.3)])


def slope(steps, errors):
    return -np.polyfit(np.log(steps), np.log(errors), 1)[0]


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("rule", RULES)
def test_bead_keeps_g_at_every_node_without_energy_drift(rule, variant):
    """10^4 steps, h = 0.01: g(q_k) = 0 to 1e-12 at every node; the energy at the step
    midpoints has equal means over the first and the last thousand steps (1e-3 relative)."""
    h, N = 0.01, 10_000
    traj = dmoc.simulate(dmoc.discretize(bead(), h, rule), q0=BEAD_Q0, v0=BEAD_V0, steps=N,
                         variant=variant).trajectory
    assert np.abs(bead_g(traj.q)).max() <= 1e-12
    E = bead_energy((traj.q[1:] + traj.q[:-1]) / 2, np.diff(traj.q, axis=0) / h)
    assert abs(E[-1000:].mean() - E[:1000].mean()) <= 1e-3 * abs(E[:1000].mean())
    assert np.ptp(E) <= 1e-2 * abs(E[0])                            # bounded, not drifting


def test_the_one_form_alone_leaks():
    """The same bead with its constraint given only as dg (midpoint retraction) drifts off
    g = 0: the node-wise check above is not vacuous."""
    traj = dmoc.simulate(dmoc.discretize(bead(one_form=True), 0.01), q0=BEAD_Q0, v0=BEAD_V0,
                         steps=10_000).trajectory
    assert np.abs(bead_g(traj.q)).max() > 1e-6


@pytest.mark.parametrize("rule, order", [("midpoint", 2), ("trapezoid", 2), ("lobatto3", 4),
                                         ("lobatto4", 6)])
def test_bead_order_against_index1_equations(rule, order):
    """Positions at T = 2 against DOP853 on the index-1 equations; g at every node of the
    step (stage nodes included) keeps each rule's order."""
    T, steps = 2.0, (40, 80, 160)
    ref = solve_ivp(bead_rhs, (0, T), np.r_[BEAD_Q0, BEAD_V0], method="DOP853",
                    rtol=1e-13, atol=1e-13).y[:2, -1]
    errors = []
    for N in steps:
        traj = dmoc.simulate(dmoc.discretize(bead(), T / N, rule), q0=BEAD_Q0, v0=BEAD_V0,
                             steps=N).trajectory
        errors.append(np.abs(traj.q[-1] - ref).max())
        stages = traj.s.reshape(N, -1, 2)
        assert np.abs(bead_g(stages)).max(initial=0.0) <= 1e-12    # interior nodes too
    assert errors[-1] > 1e-11                                       # above the floor
    assert abs(slope(steps, errors) - order) <= 0.35, errors


@pytest.mark.parametrize("rule", RULES)
def test_mixed_constraints_order_and_structure(rule):
    """Knife edge on a quartic surface: the no-slip form omega_d = 0 and g = 0 at every node,
    order 2 against DOP853 on the index-1 equations, Dirac membership at round-off."""
    T, steps = 2.0, (20, 40, 80)
    ref = solve_ivp(surface_rhs, (0, T), np.r_[SURFACE_Q0, SURFACE_V0], method="DOP853",
                    rtol=1e-13, atol=1e-13).y[:4, -1]
    errors = []
    for N in steps:
        disc = dmoc.discretize(surface_blade(), T / N, rule)
        traj = dmoc.simulate(disc, q0=SURFACE_Q0, v0=SURFACE_V0, steps=N).trajectory
        errors.append(np.abs(traj.q[-1] - ref).max())
        q = traj.q
        mid, chord = (q[1:] + q[:-1]) / 2, np.diff(q, axis=0) / disc.h
        slip = -np.sin(mid[:, 2]) * chord[:, 0] + np.cos(mid[:, 2]) * chord[:, 1]
        assert np.abs(slip).max() <= 1e-12
        assert np.abs(q[:, 3] - A2 / 2 * q[:, 0] ** 2 - A4 / 4 * q[:, 0] ** 4).max() <= 1e-12
        assert dirac_defect(disc, traj).max() <= 1e-12
    assert abs(slope(steps, errors) - 2) <= 0.35, errors


@pytest.mark.parametrize("variant", VARIANTS)
def test_spherical_pendulum_invariants(variant):
    """10^4 steps: abs(q) = l at every node, the vertical angular momentum x p_y - y p_x of
    the discrete momenta (and m (x_k y_{k+1} - x_{k+1} y_k)/h of the chords) to round-off,
    energy without drift, every step in the discrete Dirac structure."""
    m, l, h, N = 1.7, 1.3, 0.01, 10_000
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(m, l, GRAV), h)
    q0 = l * np.array([np.sin(1.0), 0.0, -np.cos(1.0)])
    v0 = np.array([0.0, 1.5, 0.0])
    traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=N, variant=variant).trajectory
    q, p = traj.q, traj.p
    assert np.abs(np.linalg.norm(q, axis=1) - l).max() <= 10 * EPS * l
    Lz0 = m * (q0[0] * v0[1] - q0[1] * v0[0])
    Lz = q[:, 0] * p[:, 1] - q[:, 1] * p[:, 0]
    chord = m * (q[:-1, 0] * q[1:, 1] - q[1:, 0] * q[:-1, 1]) / h
    assert np.abs(Lz - Lz0).max() <= 1e-12 * abs(Lz0)
    assert np.abs(chord - Lz0).max() <= 1e-11 * abs(Lz0)
    v = np.diff(q, axis=0) / h
    E = m / 2 * np.sum(v ** 2, axis=1) + m * GRAV * (q[1:, 2] + q[:-1, 2]) / 2
    assert abs(E[-1000:].mean() - E[:1000].mean()) <= 1e-3 * abs(E[:1000].mean())
    assert dirac_defect(disc, traj).max() <= 1e-12 * max(1.0, np.abs(p).max())


def test_spherical_pendulum_data():
    """L, g and the one-form 2 q^T by hand."""
    s = dmoc.systems.spherical_pendulum(2.0, 0.5, 3.0)
    q, v = np.array([0.1, -0.2, 0.3]), np.array([0.4, 0.5, -0.6])
    assert float(s.lagrangian(q, v)) == pytest.approx(v @ v - 2.0 * 3.0 * 0.3)
    assert float(s.holonomic(q)) == pytest.approx(q @ q - 0.25)
    np.testing.assert_allclose(np.array(s.constraint_matrix(q)), [2 * q])
    assert (s.n, s.m, s.n_holonomic, s.n_u) == (3, 1, 1, 2)


@pytest.mark.parametrize("variant", VARIANTS)
def test_step_equations_written_by_hand(variant):
    """Midpoint, bead: (+) left = p0 + D1 L_d - G(q0)^T lam, right = D2 L_d - p1; (-) left =
    p0 + D1 L_d, right = D2 L_d - p1 - G(q1)^T lam; constraint = g(q1) in both."""
    h = 0.1
    R = dmoc.step_residual(dmoc.discretize(bead(), h), variant)
    rng = np.random.default_rng(1)
    q0, p0, q1, p1 = rng.normal(size=(4, 2))
    lam = rng.normal(size=1)
    mid, vel = (q0 + q1) / 2, (q1 - q0) / h
    grad_V = np.array([K4 * mid[0] ** 3, GRAV])
    D1, D2 = -vel - h / 2 * grad_V, vel - h / 2 * grad_V
    G = lambda q: np.array([1 - 3 * q[0] ** 2, 1.0])
    node = {"+": (G(q0), 0), "-": (G(q1), 1)}[variant]
    rows = [p0 + D1, D2 - p1]
    rows[node[1]] = rows[node[1]] - node[0] * lam[0]
    want = np.r_[rows[0], rows[1], bead_g(q1)]
    got = np.array(R(q0=q0, p0=p0, q1=q1, p1=p1, lam=lam, s=[], u=[], h=h)).ravel()
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("rule", ["trapezoid", "lobatto3"])
def test_variants_agree(rule):
    """Same positions (and stages); p^(-)_k = p^(+)_k - A(q_k)^T lam^(+)_k, lam^(+)_k the
    multiplier at q_k, with A = dg/dq by hand."""
    disc = dmoc.discretize(bead(), 0.05, rule)
    plus, minus = (dmoc.simulate(disc, q0=BEAD_Q0, v0=BEAD_V0, steps=200, variant=v).trajectory
                   for v in VARIANTS)
    np.testing.assert_allclose(minus.q, plus.q, atol=1e-12)
    np.testing.assert_allclose(minus.s, plus.s, atol=1e-12)
    G = np.column_stack([1 - 3 * plus.q[:-1, 0] ** 2, np.ones(200)])
    np.testing.assert_allclose(minus.p[:-1], plus.p[:-1] - G * plus.lam[:, :1], atol=1e-11)


def test_initial_data_checked():
    disc = dmoc.discretize(bead(), 0.01)
    with pytest.raises(ValueError, match=r"`q0` violates the holonomic constraints"):
        dmoc.simulate(disc, q0=BEAD_Q0 + [0, 1e-6], v0=BEAD_V0, steps=2)
    with pytest.raises(ValueError, match=r"`v0` violates .* hidden constraints"):
        dmoc.simulate(disc, q0=BEAD_Q0, v0=[1.0, 0.0], steps=2)
    with pytest.raises(ValueError, match=r"dg/dq of `holonomic` must be linearly independent"):
        dmoc.MechanicalSystem(lambda q, v: ca.dot(v, v), 2, holonomic=lambda q: q[1] - q[0] ** 3,
                              constraints=lambda q: ca.horzcat(-3 * q[0] ** 2, 1))
    with pytest.raises(ValueError, match=r"`holonomic` must return shape \(k, 1\)"):
        dmoc.MechanicalSystem(lambda q, v: ca.dot(v, v), 2, holonomic=lambda q: ca.SX.ones(2, 2))


SPHERE_START = np.array([np.sin(0.5), 0.0, -np.cos(0.5)])
SPHERE_GOAL = np.array([0.0, np.sin(0.5), -np.cos(0.5)])


@pytest.mark.parametrize("variant", VARIANTS)
def test_dmoc_fully_given_goal_is_rejected_and_the_freed_goal_solves(variant):
    """Swing the spherical pendulum (l = 1) from rest to rest a quarter turn round in T = 2.
    The fully given goal over-determines g(q_N) = 0: rejected, naming z; with z free the
    optimum reaches the same goal, keeps g at every node and replays."""
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(), 0.05)
    with pytest.raises(ValueError, match=r"`q_goal` over-determines.*Leave entries \[2\] \('z',\)"):
        dmoc.OptimalControlProblem(disc, 40, q_start=SPHERE_START, q_goal=SPHERE_GOAL, variant=variant)
    problem = dmoc.OptimalControlProblem(disc, 40, q_start=SPHERE_START,
                                         q_goal=[*SPHERE_GOAL[:2], None], variant=variant)
    result = dmoc.optimize(problem)
    q = result.trajectory.q
    np.testing.assert_allclose(q[-1], SPHERE_GOAL, atol=1e-10)
    assert np.abs(np.sum(q ** 2, axis=1) - 1).max() <= 1e-12
    assert max(dmoc.diagnostics.replay_error(problem, result)) <= 1e-10
    assert result.cost == pytest.approx(5.1292012435, rel=1e-9)    # the same in both forms


def test_dmoc_boundary_checks():
    """Free start entries and an off-constraint start are refused; with k = 2 the message
    names as many entries as are in excess."""
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(), 0.05)
    with pytest.raises(ValueError, match=r"`q_start` must be fully given"):
        dmoc.OptimalControlProblem(disc, 10, q_start=[*SPHERE_START[:2], None], q_goal=[0, 0, None])
    with pytest.raises(ValueError, match=r"`q_start` violates the holonomic constraints"):
        dmoc.OptimalControlProblem(disc, 10, q_start=1.1 * SPHERE_START, q_goal=[0, 0, None])
    two = dmoc.MechanicalSystem(lambda q, v: ca.dot(v, v), 4,
                                holonomic=lambda q: ca.vertcat(q[0] - q[1] ** 3, q[2] + q[3] ** 3))
    with pytest.raises(ValueError, match=r"at most n - k = 2 .* gives 3\. Leave entries \[\d\]"):
        dmoc.OptimalControlProblem(dmoc.discretize(two, 0.1), 10, q_start=np.zeros(4),
                                   q_goal=[1.0, 1.0, None, 0.0])
