"""The quadrotor on SO(3) x R^3 (`dmoc.systems.quadrotor`, simulated on the group) against
its reduced equations written here and integrated by DOP853. With R' = R Omega^ (Omega the
body angular velocity), x the centre of mass, the thrust f along the body axis R e3 and
the body torques tau, Newton and Euler about the centre of mass read

    m x'' = f R e3 - m g e3,   J Omega' = J Omega x Omega + tau

(Lee, Leok & McClamroch, CDC 2010). The controls vary in time, u(t) below, and the step
holds u_k = u(t_k + h/2), the midpoint value, on [t_k, t_{k+1}].
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import dmoc

MASS, INERTIA, GRAVITY = 0.8, np.array([0.02, 0.03, 0.045]), 9.81
E3 = np.array([0.0, 0.0, 1.0])
R0 = Rotation.from_rotvec([0.4, -0.3, 0.6]).as_matrix()
OMEGA0 = np.array([2.0, -1.0, 3.0])                 # tumbling (body frame)
X0, V0 = np.array([0.1, -0.2, 1.0]), np.array([0.5, 0.3, -0.4])


def controls(t):
    """u(t) = (f, tau_1, tau_2, tau_3), shape (len(t), 4): the thrust about hover and small
    torques, all varying."""
    t = np.atleast_1d(t)
    return np.stack([MASS * GRAVITY * (1 + 0.3 * np.sin(2 * t)), 0.01 * np.cos(3 * t),
                     -0.02 * np.sin(t), 0.005 * (1 + t)], axis=1)


def reduced(t, z):
    """The equations above, z = (rows of R, x, x', Omega)."""
    R, v, Omega = z[:9].reshape(3, 3), z[12:15], z[15:]
    f, tau = controls(t)[0, 0], controls(t)[0, 1:]
    Omega_hat = np.array([[0, -Omega[2], Omega[1]], [Omega[2], 0, -Omega[0]],
                          [-Omega[1], Omega[0], 0]])
    dv = f / MASS * R @ E3 - GRAVITY * E3
    dOmega = np.cross(INERTIA * Omega, Omega) + tau
    return np.concatenate([(R @ Omega_hat).ravel(), v, dv, dOmega / INERTIA])


def simulate(h, steps):
    body = dmoc.systems.quadrotor(MASS, INERTIA, GRAVITY)
    u = controls(h * (np.arange(steps) + 0.5))
    result = dmoc.simulate(dmoc.discretize(body, h), q0=(R0, X0),
                           v0=np.concatenate([OMEGA0, V0]), steps=steps, controls=u)
    assert result.success, result.message
    return result.trajectory


def test_second_order_against_dop853_and_rotations_to_round_off():
    T, hs = 1.0, [0.04, 0.02, 0.01]
    z0 = np.concatenate([R0.ravel(), X0, V0, OMEGA0])
    exact = solve_ivp(reduced, (0, T), z0, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    errors = []
    for h in hs:
        traj = simulate(h, round(T / h))
        errors.append(max(np.abs(traj.R[-1].ravel() - exact[:9]).max(),
                          np.abs(traj.x[-1] - exact[9:12]).max()))
        assert traj.orthogonality_defect.max() <= 1e-13
    slopes = np.diff(np.log(errors)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - 2) <= 0.2), slopes
    assert errors[-1] <= 1e-3
    # a test of the test: it tumbles through large angles and the thrust moves it
    assert np.abs(traj.R[-1] - R0).max() > 0.5 and np.abs(traj.x[-1] - X0).max() > 0.3


def test_hover_is_an_equilibrium():
    """f = m g, tau = 0, R = I at rest stays at rest; with no thrust it falls, and since the
    trapezoid rule is exact for the linear potential m g x_3 the knots lie on
    x_3(0) - g t^2 / 2 to round-off."""
    body = dmoc.systems.quadrotor(MASS, INERTIA, GRAVITY)
    disc = dmoc.discretize(body, 0.05)
    hover = np.tile([MASS * GRAVITY, 0.0, 0.0, 0.0], (20, 1))
    traj = dmoc.simulate(disc, q0=(np.eye(3), X0), v0=np.zeros(6), steps=20,
                         controls=hover).trajectory
    assert np.abs(traj.x - X0).max() <= 1e-14 and np.abs(traj.R - np.eye(3)).max() <= 1e-15
    fall = dmoc.simulate(disc, q0=(np.eye(3), X0), v0=np.zeros(6), steps=20).trajectory
    assert np.abs(fall.x[:, 2] - (X0[2] - GRAVITY * traj.t ** 2 / 2)).max() <= 1e-12


@pytest.mark.parametrize("given, match", [(dict(mass=0.0), "mass"),
                                          (dict(gravity=-1.0), "gravity"),
                                          (dict(inertia=(1.0, 2.0)), "inertia")])
def test_bad_arguments_are_named(given, match):
    with pytest.raises(ValueError, match=match):
        dmoc.systems.quadrotor(**given)
