"""The free rigid body in space on SE(3) = SO(3) x| R^3 (`dmoc.systems.free_rigid_body` and
`dmoc.systems.spacecraft` with a mass; x the centre of mass, spatial frame) against
oracles written here. SE(3) acts on the left by (Q, b): (R, x) -> (Q R, Q x + b); the
Lagrangian L = 1/2 Omega^T J Omega + 1/2 m |x'|^2 and the discrete one (a function of
F_k = R_k^T R_{k+1} and |x_{k+1} - x_k|) are invariant, so by the discrete Noether theorem
the flow keeps both momentum maps of the action,

    linear momentum    P = m x'                      (translations b),
    angular momentum   L = x x m x' + R J Omega      (rotations Q, about the origin),

read off the discrete momenta as P_k = p_x,k and L_k = x_k x p_x,k + R_k Pi_k; the energy
1/2 Pi.J^{-1}Pi + |p_x|^2/(2m) is kept too (Moser-Veselov). Under body-frame controls
u = (tau, F) the reduced equations are

    J Omega' = J Omega x Omega + tau,   R' = R Omega^,   m x'' = R F,

integrated by DOP853 here.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import dmoc

EPS = np.finfo(float).eps
INERTIA, MASS = np.array([1.0, 2.0, 3.0]), 1.7
R0 = Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
X0, OMEGA0, V0 = np.array([0.4, -1.0, 2.0]), np.array([1.0, 0.3, -0.7]), np.array([0.5, -1.0, 0.2])


def momentum_maps(traj):
    """(P_k, L_k), each (N+1, 3), from the discrete momenta as above."""
    return traj.p_x, np.cross(traj.x, traj.p_x) + np.einsum("kij,kj->ki", traj.R, traj.Pi)


def test_both_momentum_maps_and_energy_kept_to_round_off():
    steps, h = 20000, 0.01
    body = dmoc.systems.free_rigid_body(INERTIA, mass=MASS)
    result = dmoc.simulate(dmoc.discretize(body, h), q0=(R0, X0), v0=np.r_[OMEGA0, V0],
                           steps=steps)
    assert result.success, result.message
    traj = result.trajectory
    P, L = momentum_maps(traj)
    assert np.abs(P - MASS * V0).max() <= 10 * EPS * np.sqrt(steps) * np.abs(P[0]).max()
    # x grows to |x| ~ 230: the round-off of x_k x p is relative to |x| |p|
    scale = np.abs(traj.x).max() * np.abs(P[0]).max()
    assert np.abs(L - L[0]).max() <= 10 * EPS * np.sqrt(steps) * scale
    E = 0.5 * np.einsum("ki,ki->k", traj.Pi, traj.Pi / INERTIA) + \
        0.5 * np.einsum("ki,ki->k", traj.p_x, traj.p_x) / MASS
    assert np.abs(E - E[0]).max() <= 10 * EPS * np.sqrt(steps) * E[0]
    assert traj.orthogonality_defect.max() <= 1e-13
    # a test of the test: it tumbles, it moves far, and the orbital and spin parts of L are
    # each of order one
    assert np.abs(traj.Pi - traj.Pi[0]).max() > 0.5 and np.abs(traj.x[-1] - X0).max() > 100
    assert min(np.abs(np.cross(X0, MASS * V0)).max(), np.abs(R0 @ (INERTIA * OMEGA0)).max()) > 0.5


def test_the_flow_commutes_with_the_se3_action():
    """Started from (Q R_0, Q x_0 + b) with the same body angular velocity and the
    velocity Q x'_0, the steps are (Q R_k, Q x_k + b): the discrete flow is SE(3)-equivariant."""
    Q, b = Rotation.from_rotvec([-1.0, 0.4, 2.2]).as_matrix(), np.array([3.0, -2.0, 0.5])
    disc = dmoc.discretize(dmoc.systems.free_rigid_body(INERTIA, mass=MASS), 0.05)
    one = dmoc.simulate(disc, q0=(R0, X0), v0=np.r_[OMEGA0, V0], steps=200).trajectory
    moved = dmoc.simulate(disc, q0=(Q @ R0, Q @ X0 + b), v0=np.r_[OMEGA0, Q @ V0],
                          steps=200).trajectory
    assert np.abs(moved.x - one.x).max() > 1.0      # a test of the test: far from the identity
    steps = 200
    assert np.abs(moved.R - Q @ one.R).max() <= 10 * EPS * np.sqrt(steps)
    # x reaches |x| ~ 15: its round-off is relative to that
    assert np.abs(moved.x - (one.x @ Q.T + b)).max() <= 10 * EPS * np.sqrt(steps) * np.abs(moved.x).max()
    assert np.abs(moved.Pi - one.Pi).max() <= 10 * EPS * np.sqrt(steps) * np.abs(one.Pi).max()


def controls(t):
    """u(t) = (tau, F), shape (len(t), 6), body frame: small torques and a thrust mostly
    along the body axis e3, all varying."""
    t = np.atleast_1d(t)
    return np.stack([0.3 * np.cos(3 * t), -0.2 * np.sin(t), 0.1 * (1 + t),
                     0.2 * np.sin(2 * t), -0.1 * np.ones_like(t), 2.0 + np.cos(t)], axis=1)


def reduced(t, z):
    """The equations above, z = (rows of R, x, x', Omega)."""
    R, v, Omega = z[:9].reshape(3, 3), z[12:15], z[15:]
    tau, F = controls(t)[0, :3], controls(t)[0, 3:]
    Omega_hat = np.array([[0, -Omega[2], Omega[1]], [Omega[2], 0, -Omega[0]],
                          [-Omega[1], Omega[0], 0]])
    dOmega = (np.cross(INERTIA * Omega, Omega) + tau) / INERTIA
    return np.concatenate([(R @ Omega_hat).ravel(), v, R @ F / MASS, dOmega])


def test_body_frame_thrust_second_order_against_dop853():
    T, hs = 1.0, [0.04, 0.02, 0.01]
    z0 = np.concatenate([R0.ravel(), X0, V0, OMEGA0])
    exact = solve_ivp(reduced, (0, T), z0, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    body = dmoc.systems.spacecraft(INERTIA, mass=MASS)
    errors = []
    for h in hs:
        steps = round(T / h)
        result = dmoc.simulate(dmoc.discretize(body, h), q0=(R0, X0), v0=np.r_[OMEGA0, V0],
                               steps=steps, controls=controls(h * (np.arange(steps) + 0.5)))
        assert result.success, result.message
        traj = result.trajectory
        errors.append(max(np.abs(traj.R[-1].ravel() - exact[:9]).max(),
                          np.abs(traj.x[-1] - exact[9:12]).max()))
        assert traj.orthogonality_defect.max() <= 1e-13
    slopes = np.diff(np.log(errors)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - 2) <= 0.2), slopes
    # a test of the test: the thrust turns with the body (the force in space is R F, not F)
    drift = X0 + V0 * T
    assert np.abs(exact[9:12] - drift).max() > 0.5
    assert np.abs(traj.R[-1] - R0).max() > 0.5


@pytest.mark.parametrize("factory", [dmoc.systems.free_rigid_body, dmoc.systems.spacecraft])
@pytest.mark.parametrize("mass", [0.0, -1.0, float("nan")])
def test_bad_mass_is_named(factory, mass):
    with pytest.raises(ValueError, match="mass"):
        factory(INERTIA, mass=mass)


def test_without_mass_the_bodies_stay_on_so3():
    assert dmoc.systems.free_rigid_body(INERTIA).n_x == 0
    craft = dmoc.systems.spacecraft(INERTIA)
    assert (craft.n_x, craft.n_u) == (0, 3)
    craft = dmoc.systems.spacecraft(INERTIA, mass=MASS)
    assert (craft.n_x, craft.n_u) == (3, 6) and np.array_equal(craft.mass_matrix, MASS * np.eye(3))
