"""The group step residual against the closed form of the Lie group variational integrator
written in this file (Lee, Leok & McClamroch, CMAME 196 (2007): the discrete equations of a
rigid body in a potential, with body torques entering as h/2 of the moment): the residual's
rows are derived by automatic differentiation of L_d along the variations dR = R eta^, so
the closed form is a separate path."""

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc

H = 0.1
CENTRE = np.array([0.1, -0.2, 0.5])
MASS, GRAVITY = 1.3, 9.81
INERTIA = np.array([[1.0, 0.1, 0.0], [0.1, 2.0, -0.2], [0.0, -0.2, 3.0]])
E3 = np.array([0.0, 0.0, 1.0])


def hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def vee(A):
    """vee of a skew matrix (the skew part of A is taken by the callers)."""
    return np.array([A[2, 1], A[0, 2], A[1, 0]])


def cayley(f):
    """(I - f^/2)^{-1} (I + f^/2), by a linear solve (not the closed form the code uses)."""
    return np.linalg.solve(np.eye(3) - hat(f) / 2, np.eye(3) + hat(f) / 2)


def gravity_moment(R):
    """M with M^ = dU/dR^T R - R^T dU/dR for U = m g e3 . R rho: dU/dR = m g e3 rho^T."""
    dU = MASS * GRAVITY * np.outer(E3, CENTRE)
    return vee(dU.T @ R - R.T @ dU)


def closed_form(R0, p0, f, p1, tau, moment=gravity_moment):
    """Lee et al.'s rows: h Pi_k^ + h^2/2 (M_k + tau)^ = F J_d - J_d F^T divided by h, and
    Pi_{k+1} = (1/h) vee(J_d F - F^T J_d) + h/2 (M_{k+1} + tau), J_d = tr(J)/2 I - J."""
    F = cayley(f)
    J_d = 0.5 * np.trace(INERTIA) * np.eye(3) - INERTIA
    left = p0 + H / 2 * (moment(R0) + tau) - vee(F @ J_d - J_d @ F.T) / H
    right = vee(J_d @ F - F.T @ J_d) / H + H / 2 * (moment(R0 @ F) + tau) - p1
    return np.concatenate([left, right])


def forced_top():
    """A heavy top with a general inertia tensor, turned by body torques u."""
    rho = ca.DM(CENTRE)
    return dmoc.RigidBody(INERTIA, potential=lambda R: MASS * GRAVITY * ca.mtimes(R[2, :], rho),
                          torque=lambda R, omega, u: u, n_u=3)


@pytest.mark.parametrize("seed", range(3))
def test_rows_are_the_lie_group_variational_integrator(seed):
    rng = np.random.default_rng(seed)
    residual = dmoc.group_step_residual(dmoc.discretize(forced_top(), H))
    R0 = Rotation.random(random_state=seed).as_matrix()
    p0, f, p1, u = rng.normal(size=3), 0.3 * rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    r = np.array(residual(R0.ravel(), p0, f, p1, [], u, H)).ravel()
    expected = closed_form(R0, p0, f, p1, u)
    assert np.abs(r - expected).max() <= 1e-12 * (1 + np.abs(expected).max())
    # the closed form tells a wrong sign of the moment apart (a test of the test)
    flipped = closed_form(R0, p0, f, p1, u, moment=lambda R: -gravity_moment(R))
    assert np.abs(r - flipped).max() > 1e-3


def test_reconstruction_is_the_group_product():
    residual = dmoc.group_step_residual(dmoc.discretize(dmoc.systems.free_rigid_body(), H))
    R0, f = Rotation.random(random_state=4).as_matrix(), np.array([0.2, -0.1, 0.4])
    R1 = np.array(residual.reconstruction(R0.ravel(), f)).reshape(3, 3)
    assert np.abs(R1 - R0 @ cayley(f)).max() <= 1e-15 * 8


def test_stepped_gives_the_rows_and_the_group_product_from_one_graph():
    """`stepped` returns the residual's rows and R_{k+1} = R_k cay(f) (the closed forms
    above), and the NLP's step term that calls it inlines R_k cay(f) once: fewer
    operations than its rows and a separate reconstruction (the term computed both apart
    before)."""
    residual = dmoc.group_step_residual(dmoc.discretize(forced_top(), H))
    rng = np.random.default_rng(7)
    R0 = Rotation.random(random_state=7).as_matrix()
    p0, f, p1, u = rng.normal(size=3), 0.3 * rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    r, q1 = (np.array(v).ravel() for v in residual.stepped(R0.ravel(), p0, f, p1, [], u, H))
    expected = closed_form(R0, p0, f, p1, u)
    assert np.abs(r - expected).max() <= 1e-12 * (1 + np.abs(expected).max())
    assert np.abs(q1.reshape(3, 3) - R0 @ cayley(f)).max() <= 1e-14
    problem = dmoc.GroupOptimalControlProblem(dmoc.discretize(forced_top(), H), 3, R_start=np.eye(3),
                                              R_goal=Rotation.from_rotvec([0.0, 0.0, 0.3]).as_matrix())
    from dmoc.optimal_control.nlp.group_transcription import group_transcription
    step = group_transcription(problem).separable.terms[0].function
    apart = residual.function.n_instructions() + residual.reconstruction.n_instructions()
    assert step.n_instructions() < apart        # apart: both, plus the cost and the differences


def test_free_body_momentum_update_is_coadjoint():
    """On a solution of the left rows of the free body, Pi_{k+1} = F_k^T Pi_k (Moser-Veselov)."""
    from scipy.optimize import fsolve
    body = dmoc.systems.free_rigid_body((1.0, 2.0, 3.0))
    residual = dmoc.group_step_residual(dmoc.discretize(body, H))
    R0, p0 = np.eye(3), np.array([1.0, 0.6, 0.6])
    rows = lambda f: np.array(residual(R0.ravel(), p0, f, np.zeros(3), [], [], H)).ravel()  # noqa: E731
    f = fsolve(lambda f: rows(f)[:3], H * p0 / np.array([1.0, 2.0, 3.0]), xtol=1e-14)
    assert np.abs(rows(f)[3:] - cayley(f).T @ p0).max() <= 1e-12


def test_rule_other_than_the_group_one_is_refused():
    with pytest.raises(ValueError, match="rule"):
        dmoc.discretize(dmoc.systems.free_rigid_body(), H, rule="lobatto3")


def test_residual_refuses_a_vector_space_discretization():
    with pytest.raises(TypeError, match="GroupDiscretization"):
        dmoc.group_step_residual(dmoc.discretize(dmoc.systems.knife_edge(), H))


MASSES = np.array([[2.0, 0.3], [0.3, 1.5]])
STIFFNESS, DAMPING = 0.7, 0.4


def coupled_body():
    """On SO(3) x R^2: U = x_1 e1 . R e3 + k/2 |x|^2 + m g e3 . R rho, body torques u, a
    damping force -c x' on x, and one constraint row (R e1 ... the first row of R, 1, x_1)."""
    rho = ca.DM(CENTRE)
    return dmoc.RigidBody(
        INERTIA, coordinates=MASSES, n_u=3,
        potential=lambda R, x: x[0] * R[0, 2] + STIFFNESS / 2 * ca.dot(x, x)
        + MASS * GRAVITY * ca.mtimes(R[2, :], rho),
        torque=lambda R, omega, x, v, u: ca.vertcat(u, -DAMPING * v),
        constraints=lambda R, x: ca.horzcat(R[0, :], 1, x[0]))


def coupled_closed_form(R0, x0, p0, f, p1, lam, u):
    """The rows of the module docstring's closed form with the vector part (the kinetic
    energy (1/2h) dx^T M dx, U by the trapezoid rule, the force at both ends with
    v = dx/h) and the multiplier row -A(q_k)^T lam on the left rows; the constraint row
    (1/2)(A(q_k) + A(q_{k+1})) (cay^{-1}(F); dx)/h."""
    F, dx = cayley(f[:3]), f[3:]
    R1, x1 = R0 @ F, x0 + dx

    def moment(R, x):     # dU/dR = x_1 e1 e3^T + m g e3 rho^T
        dU = x[0] * np.outer([1, 0, 0], E3) + MASS * GRAVITY * np.outer(E3, CENTRE)
        return vee(dU.T @ R - R.T @ dU)

    def gradient_x(R, x):
        return np.array([R[0, 2], 0.0]) + STIFFNESS * x

    def A(R, x):
        return np.concatenate([R[0], [1.0, x[0]]])[None]

    J_d = 0.5 * np.trace(INERTIA) * np.eye(3) - INERTIA
    force = -DAMPING * dx / H
    left = np.concatenate([p0[:3] + H / 2 * (moment(R0, x0) + u) - vee(F @ J_d - J_d @ F.T) / H,
                           p0[3:] - MASSES @ dx / H + H / 2 * (force - gradient_x(R0, x0))])
    right = np.concatenate([vee(J_d @ F - F.T @ J_d) / H + H / 2 * (moment(R1, x1) + u),
                            MASSES @ dx / H + H / 2 * (force - gradient_x(R1, x1))]) - p1
    xi = np.concatenate([2 * vee(F - F.T) / (1 + np.trace(F)), dx]) / H
    constraint = 0.5 * (A(R0, x0) + A(R1, x1)) @ xi
    return np.concatenate([left - A(R0, x0).T @ lam, right, constraint])


@pytest.mark.parametrize("seed", range(3))
def test_rows_with_coordinates_and_constraints(seed):
    rng = np.random.default_rng(seed)
    residual = dmoc.group_step_residual(dmoc.discretize(coupled_body(), H))
    assert (residual.n, residual.m) == (5, 1)
    R0 = Rotation.random(random_state=seed).as_matrix()
    x0, p0, p1, u, lam = (rng.normal(size=k) for k in (2, 5, 5, 3, 1))
    f = np.concatenate([0.3 * rng.normal(size=3), 0.1 * rng.normal(size=2)])
    r = np.array(residual(np.concatenate([R0.ravel(), x0]), p0, f, p1, lam, u, H)).ravel()
    expected = coupled_closed_form(R0, x0, p0, f, p1, lam, u)
    assert np.abs(r - expected).max() <= 1e-12 * (1 + np.abs(expected).max())
    # the multiplier sits on the left rows (the d'Alembert node q_k) only, as -A(q_k)^T
    shifted = np.array(residual(np.concatenate([R0.ravel(), x0]), p0, f, p1, lam + 1.0, u, H)).ravel()
    A0 = np.concatenate([R0[0], [1.0, x0[0]]])
    assert np.abs((shifted - r)[:5] + A0).max() <= 1e-12 and not np.any((shifted - r)[5:])
