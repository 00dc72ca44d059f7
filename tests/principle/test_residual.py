"""The step residual of the (+)/(-) discrete LDAP principles against closed forms by hand.

Oracles, none taken from the code under test:
- discrete Lagrangians (midpoint and trapezoid), discrete forces, A(q) and omega_d written
  out by hand below for a system with a configuration-dependent mass matrix, a gyroscopic
  term, a nonlinear potential, two configuration-dependent constraints and a force with
  controls and damping (n = 4, m = 2, n_u = 2); D1 L_d, D2 L_d by casadi AD of that
  hand-written L_d (a separate code path from dmoc.discretize / dmoc.principle);
- the closed forms (37) and (41) assembled from them, and the sums (46)/(47) by hand;
- Stormer-Verlet written out by hand (trapezoid L_d of a separable L);
- DOP853 at rtol = atol = 1e-13 for the continuous equations of a pendulum-like system;
- (+) and (-) runs of the same data, which must agree as docs/theory.md states.
"""

import functools

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc import diagnostics
from dmoc.systems import knife_edge

RULES = ("midpoint", "trapezoid")
VARIANTS = ("+", "-")
N_, M_, NU_ = 4, 2, 2
M0 = np.array([[2.0, 0.3, 0.0, 0.1],
               [0.3, 1.5, 0.2, 0.0],
               [0.0, 0.2, 1.0, 0.1],
               [0.1, 0.0, 0.1, 0.8]])


# ---------------------------------------------------------------------------------------
# The test system, written once; everything discrete about it is written by hand below.


def lagrangian(q, v):
    """L = v^T M(q) v / 2 + g(q).v - V(q): q-dependent mass, gyroscopic term, potential."""
    M = ca.DM(M0) + ca.diag(ca.vertcat(0.3 * ca.sin(q[2]) ** 2, 0.2 * q[0] ** 2, 0,
                                       0.1 * ca.cos(q[1]) ** 2))
    V = -ca.cos(q[0]) + 0.5 * q[1] ** 2 * q[2] + 0.3 * ca.exp(0.2 * q[3]) + 0.1 * q[0] * q[3]
    return 0.5 * ca.dot(v, ca.mtimes(M, v)) + 0.4 * q[0] * v[1] - V


def constraints(q):
    """A(q), shape (2, 4)."""
    return ca.vertcat(ca.horzcat(1, 0.3 * ca.sin(q[2]), -0.8 * ca.cos(q[3]), 0),
                      ca.horzcat(0, 1, -0.8 * ca.sin(q[3]), 0.2 * q[0]))


def force(q, v, u):
    """Controls through a q-dependent input matrix, plus q-dependent damping."""
    return (ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1], 0.5 * u[0] * u[1])
            - 0.1 * (1 + q[0] ** 2) * v)


@functools.lru_cache(maxsize=None)
def general_system():
    return dmoc.MechanicalSystem(lagrangian, N_, constraints=constraints, force=force, n_u=NU_)


def L_d_by_hand(rule, q0, q1, h):
    v = (q1 - q0) / h
    if rule == "midpoint":
        return h * lagrangian((q0 + q1) / 2, v)
    return h / 2 * (lagrangian(q0, v) + lagrangian(q1, v))


def forces_by_hand(rule, q0, q1, u, h):
    """(f_d^-, f_d^+): h/2 f at the midpoint twice, or h/2 f at each end (trapezoid)."""
    v = (q1 - q0) / h
    if rule == "midpoint":
        f = h / 2 * force((q0 + q1) / 2, v, u)
        return f, f
    return h / 2 * force(q0, v, u), h / 2 * force(q1, v, u)


@functools.lru_cache(maxsize=None)
def closed_form(variant, rule):
    """Closed forms (37) (variant "+") and (41) (variant "-"), rows [left, right, omega_d]."""
    q0, p0, q1, p1 = (ca.SX.sym(x, N_) for x in ("q0", "p0", "q1", "p1"))
    lam, u, h = ca.SX.sym("lam", M_), ca.SX.sym("u", NU_), ca.SX.sym("h")
    L_d = L_d_by_hand(rule, q0, q1, h)
    D1, D2 = ca.gradient(L_d, q0), ca.gradient(L_d, q1)
    f_minus, f_plus = forces_by_hand(rule, q0, q1, u, h)
    if variant == "+":
        left = p0 + D1 + f_minus - ca.mtimes(constraints(q0).T, lam)
        right = D2 + f_plus - p1
    else:
        left = p0 + D1 + f_minus
        right = D2 + f_plus - p1 - ca.mtimes(constraints(q1).T, lam)
    omega_d = ca.mtimes(constraints((q0 + q1) / 2), (q1 - q0) / h)
    return ca.Function("closed_form", [q0, p0, q1, p1, lam, u, h],
                       [ca.vertcat(left, right, omega_d)])


def hand_residual_norms(traj, rule):
    """Max-norm of the closed form at every step of a trajectory, shape (N,)."""
    R = closed_form(traj.variant, rule)
    return np.array([np.abs(np.array(R(traj.q[k], traj.p[k], traj.q[k + 1], traj.p[k + 1],
                                         traj.lam[k], traj.u[k], traj.h))).max()
                     for k in range(traj.steps)])


def allowed_velocity(q, rng):
    """A random v in ker A(q)."""
    A = np.array(ca.DM(constraints(ca.DM(q))))
    r = rng.normal(size=N_)
    return r - np.linalg.pinv(A) @ (A @ r)


# ---------------------------------------------------------------------------------------
# Residual from the action sum == closed forms (37) and (41)


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_step_residual_matches_closed_form(variant, rule):
    rng = np.random.default_rng(1)
    disc = dmoc.discretize(general_system(), 0.1, rule)
    res = dmoc.StepResidual(disc, variant)
    assert res.size == 2 * N_ + M_
    assert res.rows == {"left": slice(0, 4), "right": slice(4, 8), "stage": slice(8, 8),
                        "constraint": slice(8, 10)}
    R = closed_form(variant, rule)
    for _ in range(20):
        q0, p0, q1, p1 = (rng.normal(size=N_) for _ in range(4))
        lam, u, h = rng.normal(size=M_), rng.normal(size=NU_), rng.uniform(0.05, 0.5)
        got = np.array(res(q0, p0, q1, p1, lam, [], u, h)).ravel()
        want = np.array(R(q0, p0, q1, p1, lam, u, h)).ravel()
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_closed_form_derivatives_match_finite_differences():
    """The oracle's AD gradient of the hand-written L_d agrees with central differences."""
    rng = np.random.default_rng(2)
    q0, q1, h = rng.normal(size=N_), rng.normal(size=N_), 0.2
    for rule in RULES:
        a, b, hs = ca.SX.sym("a", N_), ca.SX.sym("b", N_), ca.SX.sym("h")
        F = ca.Function("Ld", [a, b, hs], [L_d_by_hand(rule, a, b, hs)])
        G = ca.Function("dLd", [a, b, hs], [ca.gradient(F(a, b, hs), a)])
        e, d = np.eye(N_), 1e-6
        fd = [(float(F(q0 + d * e[i], q1, h)) - float(F(q0 - d * e[i], q1, h))) / (2 * d)
              for i in range(N_)]
        np.testing.assert_allclose(np.array(G(q0, q1, h)).ravel(), fd, rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_action_sum_matches_hand_sums(variant, rule):
    """(46): sum L_d(q_k, q_k^+) + p_{k+1}.(q_{k+1} - q_k^+); (47): sum L_d(q_{k+1}^-, q_{k+1})
    - p_k.(q_k - q_{k+1}^-), at random values (p_1..p_N for (46), p_0..p_{N-1} for (47))."""
    rng = np.random.default_rng(3)
    N, h = 5, 0.13
    disc = dmoc.discretize(general_system(), h, rule)
    a, b = ca.SX.sym("a", N_), ca.SX.sym("b", N_)
    Ld = ca.Function("Ld", [a, b], [L_d_by_hand(rule, a, b, h)])
    q = [rng.normal(size=N_) for _ in range(N + 1)]
    aux = [rng.normal(size=N_) for _ in range(N)]
    p = [rng.normal(size=N_) for _ in range(N)]
    got = float(dmoc.action_sum(disc, variant, q, aux, p, [np.zeros(0)] * N, h))
    if variant == "+":
        want = sum(float(Ld(q[k], aux[k])) + p[k] @ (q[k + 1] - aux[k]) for k in range(N))
    else:
        want = sum(float(Ld(aux[k], q[k + 1])) - p[k] @ (q[k] - aux[k]) for k in range(N))
    assert got == pytest.approx(want, rel=1e-13, abs=1e-13)


# ---------------------------------------------------------------------------------------
# No constraints: trapezoid L_d of a separable L is Stormer-Verlet

SV_M = np.array([[2.0, 0.5], [0.5, 1.0]])


def sv_potential(q):
    return -2 * ca.cos(q[0]) - ca.cos(q[1]) + 0.3 * q[0] ** 2 * q[1]


def sv_grad(q):
    return np.array([2 * np.sin(q[0]) + 0.6 * q[0] * q[1], np.sin(q[1]) + 0.3 * q[0] ** 2])


@functools.lru_cache(maxsize=None)
def pendulum_like():
    return dmoc.MechanicalSystem(
        lambda q, v: 0.5 * ca.dot(v, ca.mtimes(ca.DM(SV_M), v)) - sv_potential(q), 2)


def stormer_verlet(q0, p0, h, steps):
    q, p = [np.array(q0, float)], [np.array(p0, float)]
    Minv = np.linalg.inv(SV_M)
    for _ in range(steps):
        p_half = p[-1] - h / 2 * sv_grad(q[-1])
        q.append(q[-1] + h * Minv @ p_half)
        p.append(p_half - h / 2 * sv_grad(q[-1]))
    return np.array(q), np.array(p)


@pytest.mark.parametrize("variant", VARIANTS)
def test_trapezoid_is_stormer_verlet(variant):
    q0, p0, h, N = np.array([0.9, -0.4]), np.array([0.3, 1.1]), 0.05, 100
    disc = dmoc.discretize(pendulum_like(), h, "trapezoid")
    traj = dmoc.simulate(disc, q0=q0, p0=p0, steps=N, variant=variant).trajectory
    q, p = stormer_verlet(q0, p0, h, N)
    assert np.abs(traj.q - q).max() <= 1e-13
    assert np.abs(traj.p - p).max() <= 1e-13
    assert traj.lam.shape == (N, 0) and traj.mu.shape == (0,)
    # And not by accident: the midpoint rule is a different scheme on this system.
    mid = dmoc.simulate(dmoc.discretize(pendulum_like(), h), q0=q0, p0=p0, steps=N).trajectory
    assert np.abs(mid.q - q).max() > 1e-5


def pendulum_reference(q0, v0, t):
    """DOP853 solution of M q'' = -grad V at the times t."""
    Minv = np.linalg.inv(SV_M)
    sol = solve_ivp(lambda _, z: np.concatenate([z[2:], -Minv @ sv_grad(z[:2])]),
                    (t[0], t[-1]), np.concatenate([q0, v0]), method="DOP853", t_eval=t,
                    rtol=1e-13, atol=1e-13)
    assert sol.success, sol.message
    return sol.y[:2].T


@pytest.mark.parametrize("variant", VARIANTS)
def test_midpoint_and_trapezoid_differ_both_order_two(variant):
    q0, v0, T, steps = np.array([0.9, -0.4]), np.array([0.3, 1.1]), 3.0, (20, 40, 80, 160)
    reference = pendulum_reference(q0, v0, np.linspace(0, T, steps[-1] + 1))
    finals = {}
    for rule in RULES:
        errors = []
        for N in steps:
            disc = dmoc.discretize(pendulum_like(), T / N, rule)
            traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=N, variant=variant).trajectory
            errors.append(np.abs(traj.q - reference[::steps[-1] // N]).max())
        assert min(errors) > 1e-6, errors            # far above round-off: the slope is real
        slope = np.polyfit(np.log(T / np.array(steps)), np.log(errors), 1)[0]
        assert abs(slope - 2.0) < 0.35, (rule, slope, errors)
        finals[rule] = traj.q
    assert np.abs(finals["midpoint"] - finals["trapezoid"]).max() > 1e-5


@pytest.mark.parametrize("variant", VARIANTS)
def test_midpoint_and_trapezoid_coincide_on_flat_knife_edge(variant):
    """L has no q-dependence, so both rules give the same L_d and the same trajectory."""
    q0, v0 = [0.1, -0.2, 0.4], [1.1 * np.cos(0.4), 1.1 * np.sin(0.4), 0.9]
    trajs = [dmoc.simulate(dmoc.discretize(knife_edge(mass=1.3, inertia=0.7), 0.05, rule),
                           q0=q0, v0=v0, steps=100, variant=variant).trajectory
             for rule in RULES]
    a, b = trajs
    for field in ("q", "p", "lam", "mu"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=0, atol=1e-13)


# ---------------------------------------------------------------------------------------
# Every computed step satisfies the residual; (+) and (-) agree as stated


@functools.lru_cache(maxsize=None)
def general_run(variant, rule, steps=30, h=0.05):
    rng = np.random.default_rng(4)
    q0 = np.array([0.2, -0.3, 0.5, 0.1])
    v0 = 0.8 * allowed_velocity(q0, rng)
    controls = rng.uniform(-1, 1, size=(steps, NU_))
    disc = dmoc.discretize(general_system(), h, rule)
    res = dmoc.simulate(disc, q0=q0, v0=v0, steps=steps, controls=controls, variant=variant)
    assert res.success, res.message
    return disc, res.trajectory, controls


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_every_step_satisfies_the_residual(variant, rule):
    disc, traj, controls = general_run(variant, rule)
    assert np.array_equal(traj.u, controls)
    assert np.abs(np.diff(traj.q, axis=0)).max() > 1e-3          # it moved
    reported = diagnostics.residual_norms(disc, traj)
    assert reported.shape == (traj.steps,) and reported.max() < 1e-10
    by_hand = hand_residual_norms(traj, rule)
    assert by_hand.max() < 1e-10
    # Not vacuous: a perturbed momentum is caught by both.
    p = traj.p.copy()
    p[10, 1] += 1e-6
    bad = dmoc.Trajectory(traj.t, traj.q, p, traj.lam, traj.u, traj.h, traj.variant, traj.mu)
    assert hand_residual_norms(bad, rule)[10] > 5e-7
    assert diagnostics.residual_norms(disc, bad)[10] > 5e-7


@pytest.mark.parametrize("rule", RULES)
def test_minus_variant_relations(rule):
    """Same data: same positions; p_k^- = p_k^+ - A(q_k)^T lam_k^+ (k = 0..N-1), mu = lam_0^+,
    lam_k^- = lam_{k+1}^+, lam_{N-1}^- = 0, p_N^- = p_N^+."""
    _, plus, _ = general_run("+", rule)
    _, minus, _ = general_run("-", rule)
    N = plus.steps
    A = [np.array(ca.DM(constraints(ca.DM(q)))) for q in plus.q]
    np.testing.assert_allclose(minus.q, plus.q, rtol=0, atol=1e-12)
    for k in range(N):
        np.testing.assert_allclose(minus.p[k], plus.p[k] - A[k].T @ plus.lam[k],
                                   rtol=0, atol=1e-11)
    np.testing.assert_allclose(minus.p[N], plus.p[N], rtol=0, atol=1e-11)
    np.testing.assert_allclose(minus.mu, plus.lam[0], rtol=0, atol=1e-11)
    np.testing.assert_allclose(minus.lam[:-1], plus.lam[1:], rtol=0, atol=1e-11)
    assert np.array_equal(minus.lam[-1], np.zeros(M_))
    assert np.abs(plus.lam).max() > 1e-2       # the impulses are not trivially zero
    assert np.array_equal(plus.mu, np.zeros(M_))
