"""Tests of dmoc.systems: the example systems and their closed-form solutions.

Oracles independent of the closed forms: the continuous Lagrange-d'Alembert equations,
reduced to an ODE here from the system's own CasADi Functions (index reduction of
A(q) qdot = 0, linear KKT solve for (qddot, lam)) and integrated with scipy's DOP853;
Lagrangians, forces and energies written out by hand below.
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from dmoc.systems import knife_edge, knife_edge_solution, rolling_disk, rolling_disk_solution

TIMES = np.linspace(0.0, 5.0, 11)


def lagrange_dalembert_rhs(system):
    """Right-hand side z' = F(z), z = (q, v), of the unforced Lagrange-d'Alembert equations.

    M qddot - A^T lam = dL/dq - (d/dq dL/dv) qdot + f and A qddot = -(dA/dq . qdot) qdot,
    with M = d^2L/dv^2, solved as one linear KKT system at every evaluation.
    """
    n, m = system.n, system.m
    q, v = ca.SX.sym("q", n), ca.SX.sym("v", n)
    L = system.lagrangian(q, v)
    M, dL_dv = ca.hessian(L, v)
    A = system.constraint_matrix(q)
    kkt = ca.blockcat([[M, -A.T], [A, ca.SX.zeros(m, m)]])
    rhs = ca.vertcat(ca.gradient(L, q) - ca.jacobian(dL_dv, q) @ v
                     + system.force(q, v, ca.DM.zeros(system.n_u)),
                     -ca.jacobian(A @ v, q) @ v)
    parts = ca.Function("kkt", [q, v], [kkt, rhs], ["q", "v"], ["K", "r"])

    def F(t, z):
        K, r = parts(z[:n], z[n:])
        sol = np.linalg.solve(np.array(K), np.array(r).ravel())
        return np.concatenate([z[n:], sol[:n]])

    return F


def integrate(system, q0, v0, times=TIMES):
    """Integrate the oracle ODE with DOP853 at rtol = atol = 1e-12; return q, v of shape (N, n)."""
    sol = solve_ivp(lagrange_dalembert_rhs(system), (times[0], times[-1]),
                    np.concatenate([q0, v0]), method="DOP853", t_eval=times,
                    rtol=1e-12, atol=1e-12)
    assert sol.success, sol.message
    return sol.y[:system.n].T, sol.y[system.n:].T


def knife_data(theta0, sigma0, w):
    """Initial data (q0, v0) of the knife edge with blade speed sigma0 and turning rate w."""
    q0 = np.array([0.3, -0.7, theta0])
    return q0, np.array([sigma0 * np.cos(theta0), sigma0 * np.sin(theta0), w])


def disk_data(radius, phi0, roll, w):
    """Initial data (q0, v0) of the rolling disk with rolling rate roll and turning rate w."""
    q0 = np.array([-0.4, 1.1, 0.2, phi0])
    return q0, np.array([radius * roll * np.cos(phi0), radius * roll * np.sin(phi0), roll, w])


def knife_energy(q, v, mass, inertia, incline, gravity):
    return (mass / 2 * (v[:, 0] ** 2 + v[:, 1] ** 2) + inertia / 2 * v[:, 2] ** 2
            + mass * gravity * np.sin(incline) * q[:, 0])


def disk_energy(v, mass, roll_inertia, steer_inertia):
    return mass / 2 * (v[:, 0] ** 2 + v[:, 1] ** 2) + roll_inertia / 2 * v[:, 2] ** 2 \
        + steer_inertia / 2 * v[:, 3] ** 2


# (mass, inertia, incline, gravity, theta0, sigma0, w)
KNIFE_CASES = {
    "flat-circle": (1.0, 1.0, 0.0, 9.81, 0.4, 1.3, 0.7),
    "flat-line": (2.0, 0.5, 0.0, 9.81, -1.2, -0.8, 0.0),
    "flat-spin-in-place": (1.0, 1.0, 0.0, 9.81, 0.0, 0.0, 2.0),
    "incline-turning": (1.0, 1.0, 0.3, 9.81, 0.4, 0.5, 1.1),
    "incline-turning-fast-backwards": (3.0, 0.2, -0.2, 9.81, -1.0, -1.0, -2.5),
    "incline-straight": (1.0, 1.0, 0.3, 9.81, 2.0, 2.0, 0.0),
    "incline-straight-across": (0.5, 2.0, 0.5, 1.62, np.pi / 2, 1.0, 0.0),
    "incline-slow-turn": (1.0, 1.0, 0.3, 9.81, 0.9, 0.5, 1e-3),
    "incline-very-slow-turn": (1.0, 1.0, 0.3, 9.81, 0.9, 0.5, 1e-7),
    "incline-turn-across-series-switch": (1.0, 1.0, 0.3, 9.81, -0.6, 1.5, 0.02),
    "incline-from-rest": (1.0, 1.0, 0.4, 9.81, 0.7, 0.0, 0.8),
}

# (mass, radius, roll_inertia, steer_inertia, phi0, roll, w)
DISK_CASES = {
    "turning": (1.0, 1.0, None, None, 0.3, 1.5, 0.6),
    "turning-custom-inertia": (2.5, 0.4, 0.7, 0.05, -2.0, -3.0, 1.7),
    "straight": (1.0, 0.5, None, None, 1.0, 2.0, 0.0),
    "spin-in-place": (1.0, 1.0, None, None, 0.5, 0.0, 1.0),
    "very-slow-turn": (1.0, 1.0, 0.3, 0.2, 0.5, 1.0, 1e-9),
}


@pytest.mark.parametrize("case", KNIFE_CASES.values(), ids=KNIFE_CASES.keys())
def test_knife_edge_solution_matches_lagrange_dalembert_ode(case):
    mass, inertia, incline, gravity, theta0, sigma0, w = case
    q0, v0 = knife_data(theta0, sigma0, w)
    system = knife_edge(mass, inertia, incline, gravity)
    q_ode, v_ode = integrate(system, q0, v0)
    q, v = knife_edge_solution(TIMES, q0, v0, incline=incline, gravity=gravity)
    assert q.shape == v.shape == (TIMES.size, 3)
    np.testing.assert_allclose(q, q_ode, rtol=0, atol=1e-8)
    np.testing.assert_allclose(v, v_ode, rtol=0, atol=1e-8)


@pytest.mark.parametrize("case", DISK_CASES.values(), ids=DISK_CASES.keys())
def test_rolling_disk_solution_matches_lagrange_dalembert_ode(case):
    mass, radius, roll_inertia, steer_inertia, phi0, roll, w = case
    q0, v0 = disk_data(radius, phi0, roll, w)
    system = rolling_disk(mass, radius, roll_inertia, steer_inertia)
    q_ode, v_ode = integrate(system, q0, v0)
    q, v = rolling_disk_solution(TIMES, q0, v0, radius=radius)
    assert q.shape == v.shape == (TIMES.size, 4)
    np.testing.assert_allclose(q, q_ode, rtol=0, atol=1e-8)
    np.testing.assert_allclose(v, v_ode, rtol=0, atol=1e-8)


def test_flat_knife_edge_runs_on_a_circle():
    q0, v0 = knife_data(0.4, 1.3, 0.7)
    q, _ = knife_edge_solution(np.linspace(0, 20, 401), q0, v0)
    radius = 1.3 / 0.7
    centre = q0[:2] + radius * np.array([-np.sin(0.4), np.cos(0.4)])
    np.testing.assert_allclose(np.hypot(*(q[:, :2] - centre).T), radius, rtol=1e-13)


def test_inclined_straight_knife_edge_is_uniformly_accelerated():
    theta0, sigma0, a = 2.0, 2.0, 9.81 * np.sin(0.3)
    q0, v0 = knife_data(theta0, sigma0, 0.0)
    q, _ = knife_edge_solution(TIMES, q0, v0, incline=0.3)
    s = sigma0 * TIMES - a * np.cos(theta0) * TIMES**2 / 2
    np.testing.assert_allclose(q[:, :2], q0[:2] + np.outer(s, [np.cos(theta0), np.sin(theta0)]),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("w", [1e-3, 1e-6, 1e-9, 1e-12, -1e-9])
def test_knife_edge_solution_is_continuous_at_w_zero(w):
    """No cancellation for tiny w: the solution tends to the straight-line one like O(w)."""
    times = np.linspace(0, 5, 6)
    q_line, v_line = knife_edge_solution(times, *knife_data(0.9, 0.5, 0.0), incline=0.3)
    q, v = knife_edge_solution(times, *knife_data(0.9, 0.5, w), incline=0.3)
    bound = 300 * abs(w) + 1e-13   # |d q / d w| <= a t^3 + ... <= 300 on [0, 5]
    np.testing.assert_allclose(q[:, :2], q_line[:, :2], rtol=0, atol=bound)
    np.testing.assert_allclose(v[:, :2], v_line[:, :2], rtol=0, atol=bound)


@pytest.mark.parametrize("case", KNIFE_CASES.values(), ids=KNIFE_CASES.keys())
def test_knife_edge_constraint_and_energy_along_solution(case):
    mass, inertia, incline, gravity, theta0, sigma0, w = case
    system = knife_edge(mass, inertia, incline, gravity)
    q, v = knife_edge_solution(np.linspace(0, 20, 201), *knife_data(theta0, sigma0, w),
                               incline=incline, gravity=gravity)
    by_hand = -np.sin(q[:, 2]) * v[:, 0] + np.cos(q[:, 2]) * v[:, 1]
    by_system = [float(system.constraint_matrix(qk) @ vk) for qk, vk in zip(q, v)]
    np.testing.assert_allclose(by_hand, 0, atol=1e-12 * (1 + np.abs(v).max()))
    np.testing.assert_allclose(by_system, 0, atol=1e-12 * (1 + np.abs(v).max()))
    E = knife_energy(q, v, mass, inertia, incline, gravity)
    # E is a small difference of kinetic and potential terms up to ~2e3: round-off scales with them
    scale = 1 + np.abs(E - mass * gravity * np.sin(incline) * q[:, 0]).max() \
        + np.abs(mass * gravity * np.sin(incline) * q[:, 0]).max()
    np.testing.assert_allclose(E, E[0], rtol=0, atol=1e-14 * scale)
    E_system = [float(system.energy(qk, vk)) for qk, vk in zip(q, v)]
    np.testing.assert_allclose(E_system, E, rtol=0, atol=1e-14 * scale)


@pytest.mark.parametrize("case", DISK_CASES.values(), ids=DISK_CASES.keys())
def test_rolling_disk_constraint_and_energy_along_solution(case):
    mass, radius, roll_inertia, steer_inertia, phi0, roll, w = case
    system = rolling_disk(mass, radius, roll_inertia, steer_inertia)
    q, v = rolling_disk_solution(np.linspace(0, 20, 201), *disk_data(radius, phi0, roll, w),
                                 radius=radius)
    by_system = np.array([np.array(system.constraint_matrix(qk) @ vk).ravel()
                          for qk, vk in zip(q, v)])
    np.testing.assert_allclose(by_system, 0, atol=1e-13 * (1 + np.abs(v).max()))
    np.testing.assert_allclose(v[:, 0] - radius * np.cos(q[:, 3]) * v[:, 2], 0, atol=1e-14)
    I = mass * radius**2 / 2 if roll_inertia is None else roll_inertia
    J = mass * radius**2 / 4 if steer_inertia is None else steer_inertia
    E = disk_energy(v, mass, I, J)
    np.testing.assert_allclose(E, E[0], rtol=1e-14)
    np.testing.assert_allclose([float(system.energy(qk, vk)) for qk, vk in zip(q, v)], E,
                               rtol=1e-14)


def test_rolling_disk_runs_on_a_circle():
    radius, phi0, roll, w = 0.5, 0.3, 1.5, 0.6
    q0, v0 = disk_data(radius, phi0, roll, w)
    q, _ = rolling_disk_solution(np.linspace(0, 30, 301), q0, v0, radius=radius)
    r = radius * roll / w
    centre = q0[:2] + r * np.array([-np.sin(phi0), np.cos(phi0)])
    np.testing.assert_allclose(np.hypot(*(q[:, :2] - centre).T), r, rtol=1e-13)


def test_system_sizes_and_names():
    k, d = knife_edge(), rolling_disk()
    assert (k.n, k.m, k.n_u, k.names) == (3, 1, 2, ("x", "y", "theta"))
    assert (d.n, d.m, d.n_u, d.names) == (4, 2, 2, ("x", "y", "theta", "phi"))


@pytest.mark.parametrize("mass, inertia, incline, gravity",
                         [(1.0, 1.0, 0.0, 9.81), (2.0, 0.3, 0.4, 1.62), (0.5, 4.0, -0.3, 9.81)])
def test_knife_edge_lagrangian_constraint_and_force_by_hand(mass, inertia, incline, gravity):
    s = knife_edge(mass, inertia, incline, gravity)
    q, v, u = np.array([0.7, -0.2, 0.9]), np.array([1.1, -0.4, 0.3]), np.array([2.0, -5.0])
    L = mass / 2 * (v[0] ** 2 + v[1] ** 2) + inertia / 2 * v[2] ** 2 \
        - mass * gravity * np.sin(incline) * q[0]
    assert float(s.lagrangian(q, v)) == pytest.approx(L, rel=1e-15)
    np.testing.assert_allclose(np.array(s.constraint_matrix(q)), [[-np.sin(0.9), np.cos(0.9), 0]])
    np.testing.assert_allclose(np.array(s.force(q, v, u)).ravel(),
                               [2 * np.cos(0.9), 2 * np.sin(0.9), -5.0])


@pytest.mark.parametrize("mass, radius, roll_inertia, steer_inertia, I, J",
                         [(1.0, 1.0, None, None, 0.5, 0.25), (2.0, 0.5, None, None, 0.25, 0.125),
                          (2.0, 0.5, 0.7, 0.1, 0.7, 0.1)])
def test_rolling_disk_lagrangian_constraint_and_force_by_hand(mass, radius, roll_inertia,
                                                              steer_inertia, I, J):
    s = rolling_disk(mass, radius, roll_inertia, steer_inertia)
    q, v = np.array([0.7, -0.2, 3.0, 0.9]), np.array([1.1, -0.4, 0.3, 2.0])
    u = np.array([2.0, -5.0])
    L = mass / 2 * (v[0] ** 2 + v[1] ** 2) + I / 2 * v[2] ** 2 + J / 2 * v[3] ** 2
    assert float(s.lagrangian(q, v)) == pytest.approx(L, rel=1e-15)
    np.testing.assert_allclose(np.array(s.constraint_matrix(q)),
                               [[1, 0, -radius * np.cos(0.9), 0], [0, 1, -radius * np.sin(0.9), 0]])
    np.testing.assert_allclose(np.array(s.force(q, v, u)).ravel(), [0, 0, 2.0, -5.0])


def test_solution_time_shapes():
    q0, v0 = knife_data(0.4, 1.3, 0.7)
    q, v = knife_edge_solution(0.0, q0, v0)
    assert q.shape == v.shape == (1, 3)
    np.testing.assert_array_equal(q[0], q0)
    np.testing.assert_allclose(v[0], v0, rtol=1e-15, atol=0)   # v is rebuilt from sigma0
    q, v = rolling_disk_solution([0.0, 1.0, 2.0], *disk_data(1.0, 0.3, 1.0, 1.0))
    assert q.shape == v.shape == (3, 4)
    with pytest.raises(ValueError, match="`t`"):
        knife_edge_solution(np.zeros((2, 2)), q0, v0)
    with pytest.raises(ValueError, match="`t`"):
        rolling_disk_solution([0.0, np.nan], *disk_data(1.0, 0.3, 1.0, 1.0))


@pytest.mark.parametrize("kwargs, error, name", [
    ({"mass": 0.0}, ValueError, "mass"), ({"mass": -1.0}, ValueError, "mass"),
    ({"mass": np.inf}, ValueError, "mass"), ({"mass": "1"}, TypeError, "mass"),
    ({"inertia": 0.0}, ValueError, "inertia"), ({"inertia": np.nan}, ValueError, "inertia"),
    ({"incline": np.inf}, ValueError, "incline"), ({"gravity": np.nan}, ValueError, "gravity"),
    ({"gravity": None}, TypeError, "gravity"),
])
def test_knife_edge_rejects_bad_parameters(kwargs, error, name):
    with pytest.raises(error, match=f"`{name}`"):
        knife_edge(**kwargs)


@pytest.mark.parametrize("kwargs, error, name", [
    ({"mass": 0.0}, ValueError, "mass"), ({"radius": -0.5}, ValueError, "radius"),
    ({"radius": np.nan}, ValueError, "radius"), ({"roll_inertia": 0.0}, ValueError, "roll_inertia"),
    ({"steer_inertia": -1.0}, ValueError, "steer_inertia"),
    ({"steer_inertia": "big"}, TypeError, "steer_inertia"),
])
def test_rolling_disk_rejects_bad_parameters(kwargs, error, name):
    with pytest.raises(error, match=f"`{name}`"):
        rolling_disk(**kwargs)


@pytest.mark.parametrize("perturbation", [1e-6, 1.0])
def test_solutions_reject_v0_off_the_constraints(perturbation):
    q0, v0 = knife_data(0.3, 1.0, 0.5)
    v0 = v0 + perturbation * np.array([-np.sin(0.3), np.cos(0.3), 0])
    with pytest.raises(ValueError, match="v0"):
        knife_edge_solution(TIMES, q0, v0)
    q0, v0 = disk_data(0.5, 0.3, 1.0, 0.5)
    with pytest.raises(ValueError, match="v0"):
        rolling_disk_solution(TIMES, q0, v0 + perturbation * np.array([0, 1, 0, 0]), radius=0.5)
    with pytest.raises(ValueError, match="v0"):   # v0 built for radius 0.5, checked with R = 1
        rolling_disk_solution(TIMES, q0, v0, radius=1.0)


def test_solutions_accept_v0_within_round_off():
    q0, v0 = knife_data(0.3, 1.0, 0.5)
    knife_edge_solution(TIMES, q0, v0 + 1e-13 * np.array([-np.sin(0.3), np.cos(0.3), 0]))
    q0, v0 = disk_data(0.5, 0.3, 1.0, 0.5)
    rolling_disk_solution(TIMES, q0, v0 + np.array([1e-13, 0, 0, 0]), radius=0.5)


@pytest.mark.parametrize("call, name", [
    (lambda: knife_edge_solution(TIMES, [0, 0], [0, 0, 0]), "q0"),
    (lambda: knife_edge_solution(TIMES, [0, 0, 0], [0, 0, np.inf]), "v0"),
    (lambda: knife_edge_solution(TIMES, [0, 0, 0], [0, 0, 0], incline=np.nan), "incline"),
    (lambda: knife_edge_solution(TIMES, [0, 0, 0], [0, 0, 0], gravity=np.inf), "gravity"),
    (lambda: rolling_disk_solution(TIMES, [0, 0, 0, 0], [0, 0, 0]), "v0"),
    (lambda: rolling_disk_solution(TIMES, [0, 0, 0, 0], [0, 0, 0, 0], radius=0.0), "radius"),
])
def test_solutions_reject_bad_arguments(call, name):
    with pytest.raises(ValueError, match=f"`{name}`"):
        call()
