"""Time-varying LQR around an optimum from the exact linearization of the discrete step.

Oracles: central finite differences of one `dmoc.simulate` step from perturbed states and
controls (exact up to round-off for a linear mass-spring chain, to O(eps^2) for the knife
edge, a constrained step); scipy's discrete algebraic Riccati solution (with it as Q_N
the recursion is stationary and its gain the infinite-horizon one); the continuous knife
edge (speed along the blade and turning rate, written in this file) integrated by DOP853
with a mass 5 % off the model's, controlled open loop and with the gains.
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import solve_discrete_are

import dmoc
from dmoc.errors import InputError
from dmoc.problems import knife_edge_parking

MASSES, STIFFNESS = np.diag([1.0, 2.0]), np.array([[2.0, -1.0], [-1.0, 1.0]])


def chain():
    """Two masses and springs, L = v^T M v / 2 - q^T K q / 2, a force on the first."""
    return dmoc.MechanicalSystem(
        lambda q, v: 0.5 * ca.dot(v, ca.mtimes(ca.DM(MASSES), v)) - 0.5 * ca.dot(q, ca.mtimes(ca.DM(STIFFNESS), q)),
        2, force=lambda q, v, u: ca.vertcat(u[0], 0), n_u=1)


def finite_differences(disc, q, p, u, eps):
    """d(q1, p1)/d(q0, p0) and d(q1, p1)/du of one simulated step, central differences."""
    n = len(q)

    def step(x, uk):
        run = dmoc.simulate(disc, q0=x[:n], p0=x[n:], steps=1, controls=uk[None], jit=False)
        return np.concatenate([run.trajectory.q[1], run.trajectory.p[1]])
    x = np.concatenate([q, p])
    A = np.column_stack([(step(x + eps * e, u) - step(x - eps * e, u)) / (2 * eps) for e in np.eye(2 * n)])
    B = np.column_stack([(step(x, u + eps * e) - step(x, u - eps * e)) / (2 * eps) for e in np.eye(len(u))])
    return A, B


def test_a_linear_flow_matches_differences_and_the_stationary_riccati_gain():
    disc = dmoc.discretize(chain(), 0.1)
    controls = np.sin(np.arange(6.0))[:, None]
    traj = dmoc.simulate(disc, q0=[0.1, -0.2], v0=[0.0, 0.3], steps=6, controls=controls, jit=False).trajectory
    A, B = dmoc.flow_jacobians(disc, traj)
    A_fd, B_fd = finite_differences(disc, traj.q[3], traj.p[3], controls[3], 1e-3)
    np.testing.assert_allclose(A[3], A_fd, rtol=0, atol=1e-9)
    np.testing.assert_allclose(B[3], B_fd, rtol=0, atol=1e-9)
    np.testing.assert_allclose(A, np.broadcast_to(A[0], A.shape), rtol=0, atol=1e-13)   # linear: constant
    Q, R = np.diag([10.0, 5.0, 1.0, 1.0]), np.array([[0.5]])
    P = solve_discrete_are(A_fd, B_fd, Q, R)
    K_inf = np.linalg.solve(R + B_fd.T @ P @ B_fd, B_fd.T @ P @ A_fd)
    gains = dmoc.tvlqr(disc, traj, Q, R, Q_N=P)
    np.testing.assert_allclose(gains.K, np.broadcast_to(K_inf, gains.K.shape), rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(gains.P[0], P, rtol=1e-8)


@pytest.mark.parametrize("rule", ["midpoint", "lobatto3"])
def test_the_constrained_step_matches_differences_of_the_simulator(rule):
    """The knife edge: the implicit function theorem on the residual (lambda_k eliminated)
    is the simulator's step map to first order; momenta along A(q_k)^T are absorbed."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule)
    rng = np.random.default_rng(3)
    controls = rng.normal(size=(5, disc.n_controls))
    traj = dmoc.simulate(disc, q0=[0.0, 0.0, 0.3], v0=[np.cos(0.3), np.sin(0.3), 0.8], steps=5,
                         controls=controls, jit=False).trajectory
    A, B = dmoc.flow_jacobians(disc, traj)
    for k in (0, 4):
        A_fd, B_fd = finite_differences(disc, traj.q[k], traj.p[k], controls[k], 1e-5)
        np.testing.assert_allclose(A[k], A_fd, rtol=0, atol=1e-8)
        np.testing.assert_allclose(B[k], B_fd, rtol=0, atol=1e-8)
        impulse = np.concatenate([np.zeros(3), [-np.sin(traj.q[k, 2]), np.cos(traj.q[k, 2]), 0.0]])
        np.testing.assert_allclose(A[k] @ impulse, 0, atol=1e-13)


def test_a_holonomic_step_stays_on_the_sphere_to_first_order():
    """The spherical pendulum, g(q) = |q|^2 - l^2: A_k and B_k map into the tangent space
    at q_{k+1} (q_{k+1} . dq_{k+1} = 0), and along curves on the sphere (rotations of
    q_k) and along every momentum they equal central differences of the simulator."""
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(), 0.05)
    q0, controls = np.array([np.sin(0.5), 0.0, -np.cos(0.5)]), np.array([[0.3, -0.2]] * 4)
    traj = dmoc.simulate(disc, q0=q0, v0=[0.0, 0.8, 0.0], steps=4, controls=controls, jit=False).trajectory
    A, B = dmoc.flow_jacobians(disc, traj)
    k, eps = 2, 1e-5
    q, p = traj.q[k], traj.p[k]
    assert np.abs(traj.q[k + 1] @ A[k][:3]).max() < 1e-14 and np.abs(traj.q[k + 1] @ B[k][:3]).max() < 1e-14

    def step(q, p):
        run = dmoc.simulate(disc, q0=q, p0=p, steps=1, controls=controls[k][None], jit=False)
        return np.concatenate([run.trajectory.q[1], run.trajectory.p[1]])
    for axis in np.eye(3)[:2]:          # q rotated about the axis by +-eps (Rodrigues)
        turned = [q * np.cos(s) + np.cross(axis, q) * np.sin(s) + axis * (axis @ q) * (1 - np.cos(s))
                  for s in (eps, -eps)]
        np.testing.assert_allclose(A[k][:, :3] @ np.cross(axis, q),
                                   (step(turned[0], p) - step(turned[1], p)) / (2 * eps), rtol=0, atol=1e-8)
    for e in np.eye(3):
        np.testing.assert_allclose(A[k][:, 3:] @ e, (step(q, p + eps * e) - step(q, p - eps * e)) / (2 * eps),
                                   rtol=0, atol=1e-8)


MASS_ERROR = 1.05


def continuous_knife_edge(t, z, u):
    """(x, y, theta, s, omega): m s' = u0, J omega' = u1, m = J = MASS_ERROR."""
    x, y, theta, s, omega = z
    return [s * np.cos(theta), s * np.sin(theta), omega, u[0] / MASS_ERROR, u[1] / MASS_ERROR]


def replay(optimum, gains):
    """The continuous plant from rest at q_0, the controls held over each step, each
    computed at the knot from the plant's (q, dL/dv) by the model (m = J = 1) when
    `gains` are given, else the optimum's."""
    z = np.zeros(5)
    for k in range(optimum.steps):
        q, v = z[:3], np.array([z[3] * np.cos(z[2]), z[3] * np.sin(z[2]), z[4]])
        u = optimum.u[k] if gains is None else gains.control(k, q, v)
        z = solve_ivp(continuous_knife_edge, (0, optimum.h), z, args=(u,), method="DOP853",
                      rtol=1e-11, atol=1e-12).y[:, -1]
    return np.linalg.norm(z[:3] - optimum.q[-1])


@pytest.fixture(scope="module")
def parking():
    """The parking optimum on 40 steps and its gains."""
    problem = knife_edge_parking(40)
    optimum = dmoc.optimize(problem).trajectory
    gains = dmoc.tvlqr(problem.disc, optimum, np.diag([1e3] * 3 + [1.0] * 3), np.eye(2),
                       Q_N=1e4 * np.eye(6))
    return problem, optimum, gains


def test_gains_bring_a_heavier_continuous_plant_ten_times_closer_to_the_optimum(parking):
    _, optimum, gains = parking
    open_loop, closed_loop = replay(optimum, None), replay(optimum, gains)
    assert open_loop > 0.05 and closed_loop < open_loop / 10


def test_simulate_with_feedback_is_the_hand_written_loop_on_a_heavier_plant(parking):
    """`simulate(plant, feedback=gains)` against a loop of one-step simulations written
    here, each under gains.control at the state reached: the same trajectory, the
    controls applied recorded, and the heavier discrete plant ten times closer than open
    loop (88.6 mm open loop, 6.5 mm closed, docs/stages/drivers.md)."""
    _, optimum, gains = parking
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.05, inertia=1.05), optimum.h)
    q, p, qs, us = optimum.q[0], optimum.p[0], [optimum.q[0]], []
    for k in range(optimum.steps):
        us.append(gains.control(k, q, p))
        step = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=us[-1][None], jit=False).trajectory
        q, p = step.q[-1], step.p[-1]
        qs.append(q)
    closed = dmoc.simulate(plant, q0=optimum.q[0], p0=optimum.p[0], steps=optimum.steps,
                           feedback=gains, jit=False)
    assert closed.success and closed.stats["completed_steps"] == optimum.steps
    np.testing.assert_allclose(closed.trajectory.q, qs, rtol=0, atol=1e-13)
    np.testing.assert_allclose(closed.trajectory.u, us, rtol=0, atol=1e-13)
    np.testing.assert_allclose(closed.trajectory.p[-1], p, rtol=0, atol=1e-13)
    open_loop = dmoc.simulate(plant, q0=optimum.q[0], p0=optimum.p[0], steps=optimum.steps,
                              controls=optimum.u, jit=False).trajectory
    miss = [np.linalg.norm(t.q[-1] - optimum.q[-1]) for t in (open_loop, closed.trajectory)]
    assert miss[0] > 0.05 and miss[1] < miss[0] / 10
    shorter = dmoc.simulate(plant, q0=optimum.q[0], p0=optimum.p[0], steps=5, feedback=gains, jit=False)
    np.testing.assert_array_equal(shorter.trajectory.q, closed.trajectory.q[:6])


def test_bad_feedback_is_named(parking):
    _, optimum, gains = parking
    disc = dmoc.discretize(dmoc.systems.knife_edge(), optimum.h)
    start = dict(q0=optimum.q[0], p0=optimum.p[0], jit=False)
    with pytest.raises(InputError, match=r"`controls` and `feedback` exclude each other"):
        dmoc.simulate(disc, steps=3, controls=optimum.u[:3], feedback=gains, **start)
    with pytest.raises(InputError, match=r"`steps` must be at most the horizon of `feedback`, 40 steps; got 41"):
        dmoc.simulate(disc, steps=41, feedback=gains, **start)
    with pytest.raises(InputError, match=r"`feedback` needs variant '\+'.*got variant '-'"):
        dmoc.simulate(disc, steps=3, feedback=gains, variant="-", **start)
    with pytest.raises(InputError, match=r"`disc` must have the step of `feedback`'s trajectory"):
        dmoc.simulate(dmoc.discretize(dmoc.systems.knife_edge(), optimum.h / 2), steps=3, feedback=gains, **start)
    with pytest.raises(InputError, match=r"`feedback` must be FeedbackGains"):
        dmoc.simulate(disc, steps=3, feedback=gains.K, **start)


def test_bad_inputs_are_named():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    minus = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=3, variant="-", jit=False).trajectory
    with pytest.raises(InputError, match=r"`trajectory` must be of the \(\+\) form"):
        dmoc.flow_jacobians(disc, minus)
    traj = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=3, jit=False).trajectory
    with pytest.raises(InputError, match=r"`Q` must have shape \(6, 6\)"):
        dmoc.tvlqr(disc, traj, np.eye(3), np.eye(2))
    with pytest.raises(InputError, match=r"`R` must be positive definite"):
        dmoc.tvlqr(disc, traj, np.eye(6), np.zeros((2, 2)))
    with pytest.raises(InputError, match=r"`Q_N` must be symmetric"):
        dmoc.tvlqr(disc, traj, np.eye(6), np.eye(2), Q_N=np.triu(np.ones((6, 6))))
    gains = dmoc.tvlqr(disc, traj, np.eye(6), np.eye(2))
    with pytest.raises(InputError, match=r"`k` must be a step of the trajectory, an int 0 <= k < 3; got 3"):
        gains.control(3, traj.q[0], traj.p[0])
