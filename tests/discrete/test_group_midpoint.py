"""The discrete Lagrangian on SO(3) x R^n_x of a configuration-dependent kinetic energy
(`GroupDiscretization` of a `FloatingBaseRobot`, `midpoint_kinetic_term`): for a constant
diag(J, M) it is the Lee-Leok-McClamroch form (1/h) tr((I - F) J_d) + (1/2h) dx^T M dx
term by term, here against the rigid body's own discretization at random data; it is
symmetric, L_d(q_{k+1}, q_k, F^T, -h) = -L_d(q_k, q_{k+1}, F, h) (which makes it of
order 2); its midpoint rotation is the square root of the increment, cay(g)^2 = cay(f)."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.discrete.group_discretization import midpoint_kinetic_term
from dmoc.mechanics.rotations import cayley, cayley_half, orthogonalized


def random_rotation(rng, size=1.0):
    return np.array(cayley(ca.DM(size * rng.normal(size=3))))


def test_midpoint_form_is_the_chord_form_for_constant_inertia():
    rng = np.random.default_rng(11)
    J = np.array([[1.0, 0.1, 0.2], [0.1, 2.0, 0.3], [0.2, 0.3, 3.0]])
    body = dmoc.RigidBody(J, coordinates=[[2.0, 0.5], [0.5, 1.0]], potential=lambda R, x: R[2, 0] * x[0])
    disc = dmoc.discretize(body, 0.1)
    for h in (0.01, 0.1, 0.7):
        R0, F = random_rotation(rng), random_rotation(rng)
        x0, x1 = rng.normal(size=2), rng.normal(size=2)
        q0, q1 = np.concatenate([R0.ravel(), x0]), np.concatenate([(R0 @ F).ravel(), x1])
        chord = float(disc.discrete_lagrangian(q0, q1, F.ravel(), h))
        midpoint = float(midpoint_kinetic_term(body.kinetic_energy, ca.DM(R0), ca.DM(x0), ca.DM(x1),
                                               ca.DM(F), h)) \
            - h / 2 * float(body.potential(R0, x0) + body.potential(R0 @ F, x1))
        assert midpoint == pytest.approx(chord, rel=1e-13, abs=1e-13)


def test_floating_base_discrete_lagrangian_is_symmetric():
    pytest.importorskip("adam.casadi", reason="the robots extra is not installed")
    robot = dmoc.FloatingBaseRobot(dmoc.mechanics.robots.example_urdf("space_arm"))
    L_d = dmoc.discretize(robot, 0.1).discrete_lagrangian
    rng = np.random.default_rng(12)
    for h in (0.05, 0.3):
        R0, F = random_rotation(rng, 0.5), random_rotation(rng, 0.5)
        x0, x1 = rng.normal(size=robot.n_x), rng.normal(size=robot.n_x)
        q0, q1 = np.concatenate([R0.ravel(), x0]), np.concatenate([(R0 @ F).ravel(), x1])
        forward = float(L_d(q0, q1, F.ravel(), h))
        assert abs(forward) > 1.0
        assert float(L_d(q1, q0, F.T.ravel(), -h)) == pytest.approx(-forward, rel=1e-13)


def test_cayley_half_is_the_square_root_of_the_increment():
    rng = np.random.default_rng(13)
    for size in (1e-3, 1.0, 10.0):
        f = size * rng.normal(size=3)
        G = np.array(cayley(cayley_half(ca.DM(f))))
        assert np.abs(G @ G - np.array(cayley(ca.DM(f)))).max() <= 1e-15 * 4


def test_orthogonalized_takes_a_rotation_off_by_1e_10_to_round_off_and_a_stack_as_each_matrix():
    """One Bjorck-Bowie step leaves |R^T R - I| of order its square (1e-20, so round-off),
    moves R by no more than the defect, and a numpy stack (K, 3, 3) gets what each matrix
    gets through CasADi."""
    rng = np.random.default_rng(14)
    rotations = np.stack([np.array(cayley(ca.DM(rng.normal(size=3)))) for _ in range(4)])
    off = rotations + 1e-10 * rng.normal(size=rotations.shape)
    stepped = orthogonalized(off)
    eye = np.eye(3)
    assert np.abs(np.swapaxes(off, 1, 2) @ off - eye).max() >= 1e-11
    assert np.abs(np.swapaxes(stepped, 1, 2) @ stepped - eye).max() <= 1e-15
    assert np.abs(stepped - off).max() <= 1e-9
    for R, S in zip(off, stepped):
        assert np.abs(np.array(orthogonalized(ca.DM(R))) - S).max() <= 1e-15
