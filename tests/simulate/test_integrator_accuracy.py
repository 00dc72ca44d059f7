"""Accuracy and structure of the Dirac integrator (`dmoc.simulate`) on nonholonomic systems.

Oracles, none taken from the code under test:
- the closed-form solutions of the knife edge (flat and inclined) and of the rolling disk
  (`dmoc.systems.*_solution`, themselves checked against DOP853 in test_systems.py), and a
  DOP853 solution (rtol = atol = 1e-13) of the reduced Lagrange-d'Alembert ODE of a knife
  edge in a potential well, written out by hand below;
- the discrete constraint omega_d = A((q0 + q1)/2)(q1 - q0)/h and the matrices A(q),
  written out by hand below;
- the discrete knife-edge equations solved by hand: p_theta is conserved, so theta_k is
  exactly linear in k (h * thetadot per step);
- a vakonomic discrete scheme (discrete action extremized with multipliers on omega_d),
  built and solved below with casadi's rootfinder: it must disagree with dmoc;
- energy: a long run has no drift (period means of E constant to round-off).
"""

import functools
from dataclasses import dataclass
from typing import Callable

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc import diagnostics
from dmoc.systems import knife_edge, knife_edge_solution, rolling_disk, rolling_disk_solution

T = 3.0                       # final time of the order runs
STEPS = (20, 40, 80, 160)     # N; h = T/N from 0.15 to 0.019, errors 1e-2 .. 1e-4
RULES = ("midpoint", "trapezoid")
VARIANTS = ("+", "-")
EPS = np.finfo(float).eps

# Knife edge data shared by the cases: mass, inertia, initial blade speed and turning rate.
KM, KJ, SIGMA0, W0 = 1.3, 0.7, 1.1, 0.9
KNIFE_Q0 = np.array([0.1, -0.2, 0.4])
KNIFE_V0 = np.array([SIGMA0 * np.cos(0.4), SIGMA0 * np.sin(0.4), W0])
# Rolling disk: mass, radius, inertias, rolling rate, turning rate.
DM_, DR, DI, DJ, OMEGA0, DW0 = 1.2, 0.8, 0.5, 0.3, 1.4, 0.9
DISK_Q0 = np.array([0.1, -0.2, 0.3, 0.5])
DISK_V0 = np.array([DR * OMEGA0 * np.cos(0.5), DR * OMEGA0 * np.sin(0.5), OMEGA0, DW0])
# Knife edge in the well V = K1 x^2/2 + K2 y^2/2 + K4 x^4/4 (midpoint and trapezoid differ).
K1, K2, K4 = 1.0, 2.0, 0.5


def knife_A(q):
    """A(q) of the knife edge, by hand: no sideways slip, -sin(theta) xdot + cos(theta) ydot = 0."""
    return np.array([[-np.sin(q[2]), np.cos(q[2]), 0.0]])


def disk_A(q):
    """A(q) of the rolling disk, by hand: xdot = R cos(phi) thetadot, ydot = R sin(phi) thetadot."""
    return np.array([[1.0, 0.0, -DR * np.cos(q[3]), 0.0],
                     [0.0, 1.0, -DR * np.sin(q[3]), 0.0]])


def knife_in_well():
    """Knife edge in a quartic well, written here (not in dmoc.systems): L = KE - V."""
    def lagrangian(q, v):
        V = K1 / 2 * q[0] ** 2 + K2 / 2 * q[1] ** 2 + K4 / 4 * q[0] ** 4
        return KM / 2 * (v[0] ** 2 + v[1] ** 2) + KJ / 2 * v[2] ** 2 - V

    return dmoc.MechanicalSystem(
        lagrangian, 3, constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0))


@functools.lru_cache(maxsize=None)
def well_reference():
    """DOP853 solution of the knife edge in the well on the finest grid, shape (161, 3).

    Reduced Lagrange-d'Alembert equations, state (x, y, theta, sigma) with sigma the speed
    along the blade: x' = sigma cos(theta), y' = sigma sin(theta), theta' = W0,
    m sigma' = -(V_x cos(theta) + V_y sin(theta))   (the constraint force drops out).
    """
    def rhs(t, z):
        x, y, th, sig = z
        Vx, Vy = K1 * x + K4 * x ** 3, K2 * y
        return [sig * np.cos(th), sig * np.sin(th), W0, -(Vx * np.cos(th) + Vy * np.sin(th)) / KM]

    t = np.linspace(0.0, T, STEPS[-1] + 1)
    sol = solve_ivp(rhs, (0.0, T), [*KNIFE_Q0, SIGMA0], method="DOP853", t_eval=t,
                    rtol=1e-13, atol=1e-13)
    assert sol.success, sol.message
    return sol.y[:3].T


def well_exact(t):
    """Reference positions at the grid times t (a subgrid of the finest one)."""
    idx = np.rint(t / T * STEPS[-1]).astype(int)
    assert np.allclose(idx * T / STEPS[-1], t, rtol=0, atol=1e-12)
    return well_reference()[idx]


@dataclass(frozen=True)
class Case:
    system: Callable
    q0: np.ndarray
    v0: np.ndarray
    exact: Callable       # t (N+1,) -> q (N+1, n)
    A: Callable           # q (n,) -> A(q) (m, n), by hand


CASES = {
    "knife-flat": Case(
        lambda: knife_edge(mass=KM, inertia=KJ), KNIFE_Q0, KNIFE_V0,
        lambda t: knife_edge_solution(t, KNIFE_Q0, KNIFE_V0)[0], knife_A),
    "knife-inclined": Case(
        lambda: knife_edge(mass=KM, inertia=KJ, incline=0.3), KNIFE_Q0, KNIFE_V0,
        lambda t: knife_edge_solution(t, KNIFE_Q0, KNIFE_V0, incline=0.3)[0], knife_A),
    "rolling-disk": Case(
        lambda: rolling_disk(mass=DM_, radius=DR, roll_inertia=DI, steer_inertia=DJ),
        DISK_Q0, DISK_V0,
        lambda t: rolling_disk_solution(t, DISK_Q0, DISK_V0, radius=DR)[0], disk_A),
    "knife-well": Case(knife_in_well, KNIFE_Q0, KNIFE_V0, well_exact, knife_A),
}
KNIFE_CASES = ("knife-flat", "knife-inclined", "knife-well")


@functools.lru_cache(maxsize=None)
def system_of(case):
    return CASES[case].system()


@functools.lru_cache(maxsize=None)
def run(case, steps, variant, rule):
    """(disc, trajectory) of the case on [0, T] with `steps` steps (cached across tests)."""
    c = CASES[case]
    disc = dmoc.discretize(system_of(case), T / steps, rule)
    res = dmoc.simulate(disc, q0=c.q0, v0=c.v0, steps=steps, variant=variant)
    assert res.success, res.message
    return disc, res.trajectory


def loglog_slope(steps, errors):
    h = T / np.asarray(steps, dtype=float)
    return np.polyfit(np.log(h), np.log(errors), 1)[0]


# ---------------------------------------------------------------------------------------
# Global order


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("case", CASES)
def test_global_order_is_two(case, variant, rule):
    """Max position error over [0, T] against the exact solution falls like h^2."""
    errors = []
    for N in STEPS:
        _, traj = run(case, N, variant, rule)
        errors.append(np.abs(traj.q - CASES[case].exact(traj.t)).max())
    # Above the round-off floor and not exact: the slope measures the scheme.
    assert min(errors) > 1e-6, errors
    assert np.all(np.diff(errors) < 0), errors
    slope = loglog_slope(STEPS, errors)
    assert abs(slope - 2.0) < 0.35, (slope, errors)


# ---------------------------------------------------------------------------------------
# Discrete constraint omega_d = 0 at every step


def omega_d_by_hand(A, q, h):
    """omega_d(q_k, q_{k+1}) = A((q_k + q_{k+1})/2) (q_{k+1} - q_k)/h, shape (N, m)."""
    return np.array([A((a + b) / 2) @ ((b - a) / h) for a, b in zip(q[:-1], q[1:])])


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("case", CASES)
def test_discrete_constraint_holds_to_round_off(case, variant, rule):
    for N in STEPS:
        disc, traj = run(case, N, variant, rule)
        by_hand = np.abs(omega_d_by_hand(CASES[case].A, traj.q, disc.h)).max(axis=1)
        assert by_hand.shape == (N,)
        assert by_hand.max() <= 1e-12
        reported = diagnostics.constraint_violation(disc, traj)
        assert reported.shape == (N,)
        assert reported.max() <= 1e-12


def test_hand_omega_d_detects_violation():
    """The hand formula is not vacuous: a perturbed knife-edge trajectory violates it, and
    diagnostics.constraint_violation reports the same numbers."""
    disc, traj = run("knife-inclined", 20, "+", "midpoint")
    q = traj.q.copy()
    q[7, 1] += 1e-3                      # push one knot sideways
    bad = dmoc.Trajectory(traj.t, q, traj.p, traj.lam, traj.u, traj.h, traj.variant)
    by_hand = np.abs(omega_d_by_hand(knife_A, q, disc.h)).max(axis=1)
    assert by_hand[6] > 1e-3 and by_hand[7] > 1e-3
    np.testing.assert_allclose(diagnostics.constraint_violation(disc, bad), by_hand,
                               rtol=1e-12, atol=1e-14)


# ---------------------------------------------------------------------------------------
# theta_k exactly linear in k: nonholonomic, not vakonomic


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("case", KNIFE_CASES)
def test_knife_edge_heading_is_linear_in_k(case, variant, rule):
    """A(q) has no theta entry and L_d no theta-dependence beyond KJ/2 thetadot^2, so the
    theta rows of (37)/(41) read KJ (theta_{k+1} - theta_k)/h = p_theta = KJ W0: theta_k =
    theta_0 + k h W0 exactly. A vakonomic scheme would bend theta (see the next test)."""
    disc, traj = run(case, STEPS[-1], variant, rule)
    theta = traj.q[:, 2]
    scale = np.abs(theta).max()
    assert np.abs(np.diff(theta, 2)).max() <= 1e-12 * scale
    np.testing.assert_allclose(np.diff(theta), disc.h * W0, rtol=1e-12, atol=0)


def vakonomic_solution(q_start, q_end, guess, h, incline):
    """Extremize sum_k L_d(q_k, q_{k+1}) + mu_k omega_d(q_k, q_{k+1}) over q_1..q_{N-1}, mu.

    Midpoint L_d of the knife edge and omega_d, written by hand. The multipliers mu_k sit on
    omega_d itself, so its gradient in theta enters the theta equation: vakonomic dynamics.
    Returns (q of shape (N+1, 3), max-norm of the stationarity residual, residual Function
    of (interior q, mu)).
    """
    N = guess.shape[0] - 1
    a = 9.81 * np.sin(incline)

    def L_d(q0, q1):
        qm, v = (q0 + q1) / 2, (q1 - q0) / h
        return h * (KM / 2 * (v[0] ** 2 + v[1] ** 2) + KJ / 2 * v[2] ** 2 - KM * a * qm[0])

    def omega_d(q0, q1):
        qm, v = (q0 + q1) / 2, (q1 - q0) / h
        return -ca.sin(qm[2]) * v[0] + ca.cos(qm[2]) * v[1]

    X, mu = ca.SX.sym("X", 3 * (N - 1)), ca.SX.sym("mu", N)
    qs = [ca.DM(q_start)] + [X[3 * i:3 * i + 3] for i in range(N - 1)] + [ca.DM(q_end)]
    S = sum(L_d(qs[k], qs[k + 1]) + mu[k] * omega_d(qs[k], qs[k + 1]) for k in range(N))
    g = ca.vertcat(ca.gradient(S, X), *[omega_d(qs[k], qs[k + 1]) for k in range(N)])
    F = ca.Function("vakonomic", [ca.vertcat(X, mu)], [g])
    solver = ca.rootfinder("vakonomic_solve", "newton", F, {"abstol": 1e-13, "max_iter": 100})
    z = np.array(solver(np.concatenate([guess[1:-1].ravel(), np.zeros(N)]))).ravel()
    q = np.vstack([q_start, z[:3 * (N - 1)].reshape(-1, 3), q_end])
    return q, np.abs(np.array(F(z))).max(), F


@pytest.mark.parametrize("case, incline", [("knife-flat", 0.0), ("knife-inclined", 0.3)])
def test_nonholonomic_differs_from_vakonomic(case, incline):
    """With the endpoints of dmoc's trajectory, the vakonomic discrete solution bends theta
    and misses the exact (Lagrange-d'Alembert) solution; dmoc's trajectory does not solve
    the vakonomic equations for any multipliers."""
    N = 20
    disc, traj = run(case, N, "+", "midpoint")
    q_vak, res, F = vakonomic_solution(traj.q[0], traj.q[-1], traj.q, disc.h, incline)
    assert res < 1e-11                                    # it solved
    assert np.abs(np.diff(q_vak[:, 2], 2)).max() > 1e-4   # theta not linear in k
    exact = CASES[case].exact(traj.t)
    err_ours, err_vak = np.abs(traj.q - exact).max(), np.abs(q_vak - exact).max()
    assert err_vak > 10 * err_ours, (err_vak, err_ours)
    # Best multipliers for dmoc's trajectory in the vakonomic equations (linear in mu).
    z = ca.SX.sym("z", 3 * (N - 1) + N)
    jac = ca.Function("vakonomic_mu_jacobian", [z], [ca.jacobian(F(z), z)[:3 * (N - 1), 3 * (N - 1):]])
    z0 = np.concatenate([traj.q[1:-1].ravel(), np.zeros(N)])
    g0 = np.array(F(z0)).ravel()[:3 * (N - 1)]
    J = np.array(jac(z0))
    mu, *_ = np.linalg.lstsq(J, -g0, rcond=None)
    assert np.abs(J @ mu + g0).max() > 1e-3


# ---------------------------------------------------------------------------------------
# Energy over 10^5 steps

LONG_H, LONG_STEPS, PERIOD = 0.01, 100_000, 500
W_LONG = 2 * np.pi / (PERIOD * LONG_H)   # theta (phi) turns once every PERIOD steps exactly


def long_case(name):
    knife_v0 = np.array([SIGMA0 * np.cos(0.4), SIGMA0 * np.sin(0.4), W_LONG])
    disk_v0 = np.array([*DISK_V0[:3], W_LONG])
    return {
        "knife-flat": (knife_edge(mass=KM, inertia=KJ), KNIFE_Q0, knife_v0),
        "knife-inclined": (knife_edge(mass=KM, inertia=KJ, incline=0.3), KNIFE_Q0, knife_v0),
        "rolling-disk": (rolling_disk(mass=DM_, radius=DR, roll_inertia=DI, steer_inertia=DJ),
                         DISK_Q0, disk_v0),
    }[name]


@pytest.mark.parametrize("name", ["knife-flat", "knife-inclined", "rolling-disk"])
def test_no_energy_drift_over_1e5_steps(name):
    """E = v.dL/dv - L at the step midpoints (potential included) does not drift.

    Why E is not exactly constant: the discrete flow is not the exact flow. For the flat
    knife edge and the disk the discrete equations conserve the blade speed (rolling rate)
    exactly, so E only shows round-off. On the incline the discrete blade speed is
    sigma_k = sigma_0 - h a/cos(h W/2) sum_{j<=k} cos(theta_j): E_k is a function of
    theta_k alone that differs from the exact (constant) energy by O(h^2), so it oscillates
    with the period of theta, PERIOD steps here. Averaged over whole periods it is constant
    up to round-off; a slope fitted to the period means is the drift.

    Round-off floor: after 10^5 steps |theta| and |y| reach ~1.3e3. The integrator solves
    for increments q_{k+1} - q_k, so its momenta carry no rounding of the positions and the
    drift measured is ~1e-12 |E| (solving for q_{k+1} itself gave ~1e-9: a random walk of
    eps 1.3e3/h = 3e-11 per step). The bound 1e-10 |E| leaves a factor ~50 and sits six
    orders below an O(h^2) drift (h^2 |E| per unit time, 1e-4 |E| over T = 1000). E itself
    is evaluated from rounded positions, (q_{k+1} - q_k)/h, hence the 1e-9 on its spread.
    """
    system, q0, v0 = long_case(name)
    disc = dmoc.discretize(system, LONG_H)
    res = dmoc.simulate(disc, q0=q0, v0=v0, steps=LONG_STEPS)
    assert res.success, res.message
    E = diagnostics.energy(disc, res.trajectory)
    assert E.shape == (LONG_STEPS,)
    scale = abs(E[0])
    means = E.reshape(-1, PERIOD).mean(axis=1)
    slope = np.polyfit(np.arange(means.size), means, 1)[0]
    assert abs(slope) * means.size <= 1e-10 * scale, (slope * means.size, scale)
    assert np.ptp(means) <= 1e-9 * scale
    if name == "knife-inclined":     # the O(h^2) oscillation is there, and bounded
        assert 1e-5 * scale < np.ptp(E) < 1e-3 * scale
    else:                            # conserved up to round-off, no oscillation
        assert np.ptp(E) <= 1e-9 * scale
    # The constraint holds all along, at the round-off floor of |q| ~ 1e3, h = 0.01.
    floor = 10 * EPS * np.abs(res.trajectory.q).max() / LONG_H
    assert diagnostics.constraint_violation(disc, res.trajectory).max() <= floor
