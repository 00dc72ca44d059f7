"""RotationTrajectory.sample: the motion between the knots on the orthogonal interpolant
R(t) = R_k cay(c f_k). Oracles, none taken from dmoc: the definition of a rotation
(|R^T R - I| at every sampled time), the stored knots, central finite differences of the
sampled R(t) and x(t) for the velocity, and DOP853 on the reduced equations of the free
body written here,

    R' = R Omega^,   Pi' = Pi x Omega,   Omega = J^{-1} Pi,

for the order of the interpolant between the knots.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import dmoc

J = np.array([1.0, 2.0, 3.0])
R0 = Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
OMEGA0 = np.array([1.0, 0.3, -0.7])


def hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def free_body(h, steps):
    disc = dmoc.discretize(dmoc.systems.free_rigid_body(tuple(J)), h)
    return dmoc.simulate(disc, q0=R0, v0=OMEGA0, steps=steps).trajectory


def rolling_ball(steps=6, h=0.1):
    """The steered Chaplygin sphere under random torques: rotations, coordinates, controls."""
    r, ball = 0.7, dmoc.systems.chaplygin_sphere(J, 1.3, 0.7, torques=True)
    v0 = np.concatenate([OMEGA0, r * np.cross(R0 @ OMEGA0, [0, 0, 1])[:2]])
    torques = np.random.default_rng(2).normal(size=(steps, 3))
    return dmoc.simulate(dmoc.discretize(ball, h), q0=(R0, [0.2, -0.1]), v0=v0, steps=steps,
                         controls=torques).trajectory


def test_every_sampled_rotation_is_orthogonal():
    h, traj = 0.05, free_body(0.05, 200)
    t = np.random.default_rng(0).uniform(0.0, traj.t[-1], 2000)
    R = traj.sample(t).R
    gram = np.einsum("kji,kjl->kil", R, R)
    assert np.abs(gram - np.eye(3)).max() <= 1e-13
    assert np.abs(np.linalg.det(R) - 1).max() <= 1e-13
    # a test of the test: the times lie between the knots, where the entrywise chord of R_k
    # and R_{k+1} is far from a rotation
    k, c = np.minimum((t / h).astype(int), traj.steps - 1), (t / h) % 1
    chord = (1 - c)[:, None, None] * traj.R[k] + c[:, None, None] * traj.R[k + 1]
    assert np.abs(np.einsum("kji,kjl->kil", chord, chord) - np.eye(3)).max() > 1e-4


def test_the_knots_are_the_stored_values():
    traj = rolling_ball()
    s = traj.sample(traj.t)
    assert np.array_equal(s.R, traj.R) and np.array_equal(s.x, traj.x)
    assert np.array_equal(s.p, traj.p) and np.array_equal(s.t, traj.t)
    assert np.array_equal(s.u, traj.u[list(range(traj.steps)) + [traj.steps - 1]])   # held
    one = traj.sample(traj.t[3])
    assert isinstance(one.t, float) and one.R.shape == (3, 3) and np.array_equal(one.R, traj.R[3])
    assert one.v.shape == one.p.shape == (5,) and one.x.shape == (2,) and one.u.shape == (3,)
    none = traj.sample([])
    assert none.R.shape == (0, 3, 3) and none.v.shape == (0, 5) and none.u.shape == (0, 3)


def test_the_velocity_is_the_derivative_of_the_sampled_motion():
    traj, d = rolling_ball(), 1e-6
    t = traj.t[2] + np.array([0.13, 0.5, 0.91]) * traj.h
    s, ahead, behind = traj.sample(t), traj.sample(t + d), traj.sample(t - d)
    dR = (ahead.R - behind.R) / (2 * d)
    body = np.einsum("kji,kjl->kil", s.R, dR)           # R^T R', skew
    omega = np.stack([body[:, 2, 1], body[:, 0, 2], body[:, 1, 0]], axis=1)
    assert np.abs(omega - s.v[:, :3]).max() <= 1e-8
    assert np.abs((ahead.x - behind.x) / (2 * d) - s.v[:, 3:]).max() <= 1e-8
    # the body turns faster or slower within the step: Omega(t) is not a constant
    assert np.abs(s.v[0, :3] - s.v[2, :3]).max() > 1e-5


def reference(T):
    """DOP853's dense solution of the reduced equations from (R0, J OMEGA0) on [0, T]."""
    def rhs(t, z):
        R, Pi = z[:9].reshape(3, 3), z[9:]
        return np.concatenate([(R @ hat(Pi / J)).ravel(), np.cross(Pi, Pi / J)])
    return solve_ivp(rhs, (0, T), np.concatenate([R0.ravel(), J * OMEGA0]), method="DOP853",
                     rtol=1e-13, atol=1e-13, dense_output=True).sol


def test_order_between_the_knots_against_dop853():
    """R(t) and Pi(t) converge at order 2 between the knots (the midpoint step's order),
    Omega(t) at order 1 (one velocity per step, as the chord's q' of a vector space); at
    c = 0.1 of each step, away from its midpoint, where Omega's first-order error
    (1/2 - c) h Omega' vanishes. Measured: 1.98, 2.00, 1.03."""
    T, sizes = 2.0, np.array([0.1, 0.05, 0.025])
    exact = reference(T)
    errors = []
    for h in sizes:
        traj = free_body(h, round(T / h))
        t = (np.arange(traj.steps) + 0.1) * h
        s, z = traj.sample(t), exact(t).T
        errors.append([np.abs(s.R - z[:, :9].reshape(-1, 3, 3)).max(),
                       np.abs(s.p - z[:, 9:]).max(), np.abs(s.v - z[:, 9:] / J).max()])
    slopes = np.polyfit(np.log(sizes), np.log(errors), 1)[0]
    assert slopes == pytest.approx([2.0, 2.0, 1.0], abs=0.15), (slopes, errors)
