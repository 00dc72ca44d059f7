"""The Chaplygin sphere on SO(3) x R^2 (`dmoc.systems.chaplygin_sphere`, simulated on the
group) against oracles not taken from dmoc: the rolling constraints written here, the
conserved energy and contact angular momentum, and the global order against DOP853 on the
Newton-Euler equations derived here.

A ball of radius r, mass m, centre of mass at its centre c = (x, y, r), inertia J about
it (body frame), rolling on the plane z = 0. With the spatial angular velocity omega
(R' = omega^ R) the contact point c - r e3 is at rest: c' = r omega x e3. Newton:
m c'' = F + (N - m g) e3, F the horizontal friction force; Euler about the centre, with
pi = R J R^T omega: pi' = (-r e3) x (F + N e3) = -r e3 x F. From c'' = r omega' x e3,
F = m r omega' x e3, so pi' = -m r^2 (omega' - (e3 . omega') e3); and
pi' = omega x pi + R J R^T omega', hence

    (R J R^T + m r^2 (I - e3 e3^T)) omega' = -omega x (R J R^T omega),
    R' = omega^ R,   (x, y)' = r P (omega x e3),

P the first two rows. The angular momentum about the contact point,
K = pi + r e3 x (m c') = pi + m r^2 (omega - (e3 . omega) e3), is constant (K' = 0 above;
the contact force passes through the contact point), and so is the energy
1/2 omega . pi + 1/2 m |c'|^2. Written with the momenta, pi = R Pi and m c' = (p_x, 0).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import dmoc

INERTIA, MASS, RADIUS = np.array([1.0, 1.5, 2.5]), 1.3, 0.7
E3 = np.array([0.0, 0.0, 1.0])
EPS = np.finfo(float).eps
R0 = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
OMEGA0 = np.array([1.0, -0.5, 2.0])             # body angular velocity


def rolling_velocity(R, Omega):
    """(x, y)' = r P (omega x e3), omega = R Omega."""
    return RADIUS * np.cross(R @ Omega, E3)[:2]


def newton_euler(t, z):
    """The reduced equations above, z = (rows of R, x, y, omega)."""
    R, omega = z[:9].reshape(3, 3), z[11:]
    inertia = R @ np.diag(INERTIA) @ R.T
    Omega_hat = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]],
                          [-omega[1], omega[0], 0]])
    mass = inertia + MASS * RADIUS ** 2 * (np.eye(3) - np.outer(E3, E3))
    domega = np.linalg.solve(mass, -np.cross(omega, inertia @ omega))
    return np.concatenate([(Omega_hat @ R).ravel(), RADIUS * np.cross(omega, E3)[:2], domega])


def simulate(h, steps, **options):
    body = dmoc.systems.chaplygin_sphere(INERTIA, MASS, RADIUS)
    v0 = np.concatenate([OMEGA0, rolling_velocity(R0, OMEGA0)])
    result = dmoc.simulate(dmoc.discretize(body, h), q0=(R0, [0.2, -0.1]), v0=v0, steps=steps,
                           **options)
    assert result.success, result.message
    return body, result.trajectory


def conserved(traj):
    """(energy, contact angular momentum K (spatial)) of each knot, from R_k and the
    momenta Pi_k, p_x,k, per the formulas of the module docstring."""
    c_momentum = np.hstack([traj.p_x, np.zeros((traj.p_x.shape[0], 1))])
    energy = 0.5 * (np.einsum("ki,ki->k", traj.Pi, traj.Pi / INERTIA)
                    + np.einsum("ki,ki->k", traj.p_x, traj.p_x) / MASS)
    return energy, np.einsum("kij,kj->ki", traj.R, traj.Pi) + RADIUS * np.cross(E3, c_momentum)


def cayley_inverse(F):
    """2 vee(F - F^T)/(1 + tr F), from the rotations alone."""
    A = F - F.T
    return 2 * np.array([A[2, 1], A[0, 2], A[1, 0]]) / (1 + np.trace(F))


def test_rolling_constraints_hold_to_round_off_at_every_step():
    """Each step rolls exactly: x_{k+1} - x_k = r P ((R_k f_k) x e3) with f_k the Cayley
    coordinates of R_k^T R_{k+1} (the discrete one-form; R_k f_k = R_{k+1} f_k, so its two
    ends agree), and every R_k is a rotation."""
    _, traj = simulate(0.02, 2000)
    f = np.array([cayley_inverse(a.T @ b) for a, b in zip(traj.R[:-1], traj.R[1:])])
    rolled = RADIUS * np.cross(np.einsum("kij,kj->ki", traj.R[:-1], f), E3)[:, :2]
    dx = np.diff(traj.x, axis=0)
    assert np.abs(dx - rolled).max() <= 1e-14 * 20
    assert traj.orthogonality_defect.max() <= 1e-13
    # the ball rolls far and turns about every axis (a test of the test)
    assert np.abs(traj.x[-1] - traj.x[0]).max() > 1.0 and np.abs(dx).max() > 0.01


def test_contact_momentum_to_round_off_and_energy_without_drift():
    """K is a discrete invariant: the rolling impulse A^T lam at q_k, the body torque
    r R^T e3^T (lam, 0) and the force lam, changes R Pi by -r e3 x (lam, 0) and r e3 x p by
    as much the other way, and the step is otherwise invariant under rotations and
    translations. The energy is not one: it oscillates by O(h^2) (halving h divides it
    by 4) and does not drift (over 8000 steps the last quarter stays as close to the start
    as the first)."""
    steps, spread = 8000, {}
    for h in (0.04, 0.02):
        body, traj = simulate(h, steps)
        E, K = conserved(traj)
        assert np.abs(K - K[0]).max() <= 10 * EPS * np.sqrt(steps) * np.abs(K[0]).max()
        err, quarter = np.abs(E - E[0]), steps // 4
        assert err[-quarter:].max() <= 1.1 * err[:quarter].max()
        spread[h] = np.ptp(E)
    assert 3.5 <= spread[0.04] / spread[0.02] <= 4.5
    # the ball rolls and turns (a test of the test: R Pi alone is far from constant)
    spin = np.einsum("kij,kj->ki", traj.R, traj.Pi)
    assert np.abs(spin - spin[0]).max() > 0.1
    # the body's energy function is the formula above
    E_body = [float(body.energy(q, p)) for q, p in zip(traj.q[::500], traj.p[::500])]
    assert np.abs(E_body - E[::500]).max() <= 1e-13 * E[0]


def test_second_order_against_dop853():
    T = 1.0
    z0 = np.concatenate([R0.ravel(), [0.2, -0.1], R0 @ OMEGA0])
    exact = solve_ivp(newton_euler, (0, T), z0, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    errors, hs = [], [0.1, 0.05, 0.025]
    for h in hs:
        _, traj = simulate(h, round(T / h))
        errors.append(max(np.abs(traj.R[-1].ravel() - exact[:9]).max(),
                          np.abs(traj.x[-1] - exact[9:11]).max()))
    slopes = np.diff(np.log(errors)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - 2) <= 0.35), slopes
    assert errors[-1] <= 1e-3


def test_steps_solve_the_shared_residual():
    """The simulator's steps and multipliers are zeros of the GroupStepResidual (the rows the
    optimizer imposes), constraint rows included."""
    disc = dmoc.discretize(dmoc.systems.chaplygin_sphere(INERTIA, MASS, RADIUS, torques=True), 0.05)
    controls = np.random.default_rng(0).normal(size=(20, 3))
    v0 = np.concatenate([OMEGA0, rolling_velocity(R0, OMEGA0)])
    traj = dmoc.simulate(disc, q0=(R0, [0.0, 0.0]), v0=v0, steps=20, controls=controls).trajectory
    residual = dmoc.group_step_residual(disc)
    r = np.array(residual.function.map(20)(traj.q[:-1].T, traj.p[:-1].T, traj.f.T, traj.p[1:].T,
                                           traj.lam.T, controls.T, 0.05))
    assert r.shape == (2 * 5 + 2, 20) and np.abs(r).max() <= 1e-13
    assert np.abs(traj.lam).max() > 1e-3          # the rolling constraint does push


@pytest.mark.parametrize("given, match", [
    (dict(q0=np.eye(3)), "pair"),
    (dict(q0=(np.eye(3), [0.0])), "q0"),
    (dict(v0=[0.0, 0.0, 1.0, 0.5, 0.0]), "constraints"),
    (dict(variant="-"), "variant"),
])
def test_bad_arguments_are_named(given, match):
    disc = dmoc.discretize(dmoc.systems.chaplygin_sphere(), 0.1)
    arguments = {**dict(q0=(np.eye(3), [0.0, 0.0]), v0=[0.0, 1.0, 0.0, 1.0, 0.0], steps=5), **given}
    with pytest.raises(ValueError, match=match):
        dmoc.simulate(disc, **arguments)


@pytest.mark.parametrize("given, match", [
    (dict(coordinates=[1.0, -1.0]), "coordinates"),
    (dict(coordinates=[1.0], constraints=lambda R, x: np.ones((2, 4))), "linearly independent"),
    (dict(constraints=lambda R: np.ones((1, 4))), "constraints"),
])
def test_bad_bodies_are_named(given, match):
    with pytest.raises(ValueError, match=match):
        dmoc.RigidBody(INERTIA, **given)

