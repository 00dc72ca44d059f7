"""Rigid bodies simulated on SO(3) (`dmoc.simulate` of a `GroupDiscretization`) against
oracles not taken from dmoc: the conserved quantities of the free body (energy and spatial
angular momentum) and of the heavy top (the vertical spatial angular momentum), written
here from R and Pi; orthogonality at every step; and the global order against DOP853 on
the reduced equations derived here,

    Pi' = Pi x Omega + M(R) + tau,   R' = R Omega^,   Omega = J^{-1} Pi,

with the gravity moment of the heavy top M = m g (R^T e3) x rho (U = m g e3 . R rho).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import dmoc

EPS = np.finfo(float).eps
INERTIA = (1.0, 2.0, 3.0)
TOP = dict(inertia=(1.0, 1.2, 0.4), mass=1.0, centre=(0.05, 0.0, 0.5), gravity=9.81)
E3 = np.array([0.0, 0.0, 1.0])


def energy(R, Pi, inertia, moment_arm=None):
    """1/2 Pi . J^{-1} Pi (+ m g e3 . R rho for the top), per row."""
    kinetic = 0.5 * np.einsum("ki,ki->k", Pi, Pi / np.asarray(inertia))
    if moment_arm is None:
        return kinetic
    return kinetic + TOP["mass"] * TOP["gravity"] * np.einsum("i,kij,j->k", E3, R, moment_arm)


def round_off(steps, scale):
    """What round-off alone can add up to over `steps` steps: 10 eps sqrt(steps) |scale|
    (a random walk of a few units of round-off per step)."""
    return 10 * EPS * np.sqrt(steps) * scale


def run(body, h, steps, R0, omega0, controls=None):
    result = dmoc.simulate(dmoc.discretize(body, h), q0=R0, v0=omega0, steps=steps,
                           controls=controls)
    assert result.success, result.message
    return result.trajectory


def test_free_body_keeps_energy_and_spatial_momentum_to_round_off():
    steps, R0 = 20000, Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
    traj = run(dmoc.systems.free_rigid_body(INERTIA), 0.05, steps, R0, [1.0, 0.3, -0.7])
    E, m = energy(traj.R, traj.Pi, INERTIA), traj.spatial_momentum
    assert np.abs(E - E[0]).max() <= round_off(steps, E[0])
    assert np.abs(m - m[0]).max() <= round_off(steps, np.abs(m[0]).max())
    assert traj.orthogonality_defect.max() <= 1e-13
    # the body tumbles (a test of the test: Pi itself is far from constant)
    assert np.abs(traj.Pi - traj.Pi[0]).max() > 0.5


def test_heavy_top_keeps_vertical_angular_momentum_to_round_off():
    steps, R0 = 20000, Rotation.from_rotvec([0.4, 0.1, 0.0]).as_matrix()
    traj = run(dmoc.systems.heavy_top(**TOP), 0.01, steps, R0, [0.5, -0.3, 8.0])
    vertical = traj.spatial_momentum[:, 2]
    assert np.abs(vertical - vertical[0]).max() <= round_off(steps, np.abs(traj.Pi).max())
    assert traj.orthogonality_defect.max() <= 1e-13
    # the horizontal components are not conserved (gravity turns them): a test of the test
    assert np.abs(traj.spatial_momentum[:, :2] - traj.spatial_momentum[0, :2]).max() > 0.1
    E = energy(traj.R, traj.Pi, TOP["inertia"], np.array(TOP["centre"]))
    assert np.abs(E - E[0]).max() <= 1e-3 * abs(E[0])       # bounded, O(h^2): not an invariant


def reference(inertia, moment, tau, R0, omega0, T):
    """DOP853 on Euler's equations with the moment M(R) and a constant body torque tau (None:
    the damping torque -c Omega)."""
    J = np.asarray(inertia)

    def rhs(t, z):
        R, Pi = z[:9].reshape(3, 3), z[9:]
        omega = Pi / J
        torque = -DAMPING * omega if tau is None else tau
        return np.concatenate([(R @ hat(omega)).ravel(), np.cross(Pi, omega) + moment(R) + torque])
    z0 = np.concatenate([R0.ravel(), J * omega0])
    z = solve_ivp(rhs, (0, T), z0, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    return z[:9].reshape(3, 3), z[9:]


def hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def top_moment(R):
    return TOP["mass"] * TOP["gravity"] * np.cross(R.T @ E3, TOP["centre"])


DAMPING = 0.4


def damped_body():
    """A free body with viscous damping tau = -c Omega (a force of the velocity of the step)."""
    return dmoc.RigidBody(INERTIA, torque=lambda R, omega, u: -DAMPING * omega)


CASES = {
    "heavy top": (lambda: dmoc.systems.heavy_top(**TOP), TOP["inertia"], top_moment, np.zeros(3)),
    "damped body": (damped_body, INERTIA, lambda R: np.zeros(3), None),
    "spacecraft": (lambda: dmoc.systems.spacecraft(INERTIA), INERTIA, lambda R: np.zeros(3),
                   np.array([0.3, -0.5, 0.2])),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_global_order_is_two_against_dop853(case):
    build, inertia, moment, tau = CASES[case]
    body, T, R0, omega0 = build(), 1.0, Rotation.from_rotvec([0.4, 0.1, -0.2]).as_matrix(), np.array([0.5, -0.3, 2.0])
    R_ref, Pi_ref = reference(inertia, moment, tau, R0, omega0, T)
    steps, errors = [20, 40, 80, 160], []
    for N in steps:
        traj = run(body, T / N, N, R0, omega0, controls=np.tile(tau, (N, 1)) if body.n_u else None)
        errors.append(max(np.abs(traj.R[-1] - R_ref).max(), np.abs(traj.Pi[-1] - Pi_ref).max()))
    slope = np.polyfit(np.log(T / np.array(steps)), np.log(errors), 1)[0]
    assert abs(slope - 2.0) < 0.35, (slope, errors)
    assert min(errors) > 1e3 * EPS         # above the round-off floor: the slope measures the scheme


def test_both_variants_give_the_same_steps():
    disc = dmoc.discretize(dmoc.systems.heavy_top(**TOP), 0.02)
    a, b = (dmoc.simulate(disc, q0=np.eye(3), v0=[0.1, 0.2, 3.0], steps=50, variant=v).trajectory
            for v in ("+", "-"))
    assert np.array_equal(a.R, b.R) and np.array_equal(a.Pi, b.Pi)


def test_steps_solve_the_shared_residual():
    """The simulator's steps are zeros of the GroupStepResidual (what the optimizer imposes)."""
    disc = dmoc.discretize(dmoc.systems.spacecraft(INERTIA), 0.05)
    controls = np.random.default_rng(0).normal(size=(30, 3))
    traj = dmoc.simulate(disc, q0=np.eye(3), v0=[0.2, 0.1, 1.0], steps=30, controls=controls).trajectory
    residual = dmoc.group_step_residual(disc)
    r = np.array(residual.function.map(30)(traj.q[:-1].T, traj.Pi[:-1].T, traj.f.T, traj.Pi[1:].T,
                                           traj.lam.T, controls.T, 0.05))
    assert np.abs(r).max() <= 1e-13
    R1 = np.array(residual.reconstruction.map(30)(traj.q[:-1].T, traj.f.T)).T.reshape(-1, 3, 3)
    assert np.abs(R1 - traj.R[1:]).max() <= 1e-14


@pytest.mark.parametrize("given, match", [
    (dict(q0=np.diag([1.0, 1.0, -1.0])), "q0"),
    (dict(q0=np.eye(3) * 1.01), "q0"),
    (dict(q0=np.eye(2)), "q0"),
    (dict(p0=[0.0, 0.0, 1.0]), "exactly one of `v0`"),
    (dict(v0=[1.0, 2.0]), "v0"),
    (dict(controls=np.zeros((5, 2))), "controls"),
    (dict(variant="x"), "variant"),
    (dict(steps=0), "steps"),
])
def test_bad_arguments_are_named(given, match):
    disc = dmoc.discretize(dmoc.systems.spacecraft(), 0.1)
    arguments = {**dict(q0=np.eye(3), v0=[0.0, 0.0, 1.0], steps=5), **given}
    with pytest.raises(ValueError, match=match):
        dmoc.simulate(disc, **arguments)


@pytest.mark.parametrize("inertia, match", [((1.0, -1.0, 2.0), "positive definite"),
                                            ([[1, 2, 0], [0, 1, 0], [0, 0, 1]], "symmetric"),
                                            ((1.0, 2.0), "inertia")])
def test_bad_inertia_is_named(inertia, match):
    with pytest.raises(ValueError, match=match):
        dmoc.RigidBody(inertia)


def test_spin_about_a_principal_axis_turns_by_arcsin_and_fails_beyond():
    """About the principal axis e3 the left rows read h Pi_3 = J_3 sin(phi) (F J_d - J_d F^T
    for F a rotation by phi about e3), so each step turns by phi = arcsin(h Omega_3), and
    no increment exists when h Omega_3 > 1: the simulator reports the failed step."""
    disc = dmoc.discretize(dmoc.systems.free_rigid_body(INERTIA), 0.1)
    traj = dmoc.simulate(disc, q0=np.eye(3), v0=[0.0, 0.0, 9.0], steps=7).trajectory
    angles = np.unwrap(np.arctan2(traj.R[:, 1, 0], traj.R[:, 0, 0]))
    assert np.abs(angles - np.arange(8) * np.arcsin(0.9)).max() <= 1e-13
    failed = dmoc.simulate(disc, q0=np.eye(3), v0=[0.0, 0.0, 11.0], steps=7, throw=False)
    assert failed.status == "newton_failed" and failed.stats["completed_steps"] == 0
    assert "step 0" in failed.message and np.array_equal(failed.trajectory.R, np.eye(3)[None])
    with pytest.raises(dmoc.SolverError, match="step 0"):
        dmoc.simulate(disc, q0=np.eye(3), v0=[0.0, 0.0, 11.0], steps=7)


def test_suslov_constraint_without_coordinates_holds_to_round_off():
    """Suslov's body: Omega . e3 = 0 in the body frame (a constant one-form on SO(3), no
    vector coordinates). Its discrete one-form (f_k . e3)/h vanishes, so every increment
    turns about an axis orthogonal to e3: checked from the rotations, e3 . cay^{-1}(R_k^T
    R_{k+1}) = 0 to round-off, while the body tumbles."""
    inertia = np.array([[2.0, 0.3, 0.4], [0.3, 1.5, 0.2], [0.4, 0.2, 1.0]])
    body = dmoc.RigidBody(inertia, constraints=lambda R: np.array([[0.0, 0.0, 1.0]]))
    traj = run(body, 0.05, 400, np.eye(3), [1.0, -0.5, 0.0])
    F = np.einsum("kji,kjl->kil", traj.R[:-1], traj.R[1:])
    axis_e3 = (F[:, 1, 0] - F[:, 0, 1]) / (1 + np.trace(F, axis1=1, axis2=2))
    assert np.abs(axis_e3).max() <= 1e-15 * 10 and traj.lam.shape == (400, 1)
    assert np.abs(traj.lam).max() > 1e-4 and traj.orthogonality_defect.max() <= 1e-13
    assert np.abs(traj.R[-1] - np.eye(3)).max() > 0.5
