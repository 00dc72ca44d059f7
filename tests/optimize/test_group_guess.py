"""The default guess of a problem on SO(3) x R^n_x: the geodesic between the end rotations
and the segment between the end coordinates, eased into an end where the body is at rest
(the quintic s(t) = 10 t^3 - 15 t^4 + 6 t^5 of a rest-to-rest motion, written here), its
increments the Cayley coordinates of R_k^T R_{k+1} (cay written here)."""

import numpy as np
from scipy.spatial.transform import Rotation

import dmoc
from dmoc.optimal_control.nlp.group_transcription import group_transcription
from dmoc.optimal_control.solver.group_solving import geodesic_guess, timing

N, TURN = 8, np.array([0.3, -0.9, 1.1])


def cay(f):
    F = np.array([[0, -f[2], f[1]], [f[2], 0, -f[0]], [-f[1], f[0], 0]])
    return np.linalg.solve(np.eye(3) - F / 2, np.eye(3) + F / 2)


def problem(**ends):
    body = dmoc.systems.chaplygin_sphere((1.0, 2.0, 2.5), 1.3, 0.7, torques=True)
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(body, 0.25), N, R_start=np.eye(3),
                                           R_goal=Rotation.from_rotvec(TURN).as_matrix(),
                                           x_start=[0.0, 0.0], x_goal=[1.0, 0.5], **ends)


def test_a_rest_to_rest_guess_eases_in_and_out_along_the_geodesic():
    p = problem()
    t = np.arange(N + 1) / N
    s = 10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5
    assert np.abs(timing(p) - s).max() <= 1e-15
    T = group_transcription(p)
    x = geodesic_guess(p, T)
    q, f = T.x_layout.unpack(x, "q").T, T.x_layout.unpack(x, "f").T
    R = q[:, :9].reshape(-1, 3, 3)
    expected = Rotation.from_rotvec(np.outer(s, TURN)).as_matrix()
    assert np.abs(R - expected).max() <= 1e-14
    for k in range(N):
        assert np.abs(R[k] @ cay(f[k, :3]) - R[k + 1]).max() <= 1e-14
    assert np.abs(np.diff(q[:, 9:], axis=0) - f[:, 3:]).max() <= 1e-15
    assert np.abs(q[-1, 9:] - [1.0, 0.5]).max() <= 1e-15


def test_a_moving_end_keeps_the_constant_speed_there():
    spin = problem(omega_start=[0.0, 0.0, 0.5])       # rolls in place about e3: allowed
    t = np.arange(N + 1) / N
    s = timing(spin)
    # s'(0) = 1 (no easing at the moving start), s'(1) = 0 (the goal at rest): the quintic
    # of those slopes, t - 6 t^3 + 8 t^4 - 3 t^5 + 10 t^3 - 15 t^4 + 6 t^5
    assert np.abs(s - (t + 4 * t ** 3 - 7 * t ** 4 + 3 * t ** 5)).max() <= 1e-15
    up = Rotation.from_rotvec(TURN).as_matrix().T @ [0.0, 0.0, 1.0]       # e3 in the goal's body frame
    both = problem(omega_start=[0.0, 0.0, 0.5], omega_goal=-0.2 * up)
    assert np.abs(timing(both) - t).max() <= 1e-15


def test_rotation_matrices_of_a_stack_are_each_rodrigues():
    """`rotation_matrix` on a stack of rotation vectors (the geodesic's knots at once) gives
    exp(phi^) of each (scipy's), the zero vector and one below 1e-12 included."""
    from dmoc.optimal_control.statement.group_problem import rotation_matrix
    phi = np.random.default_rng(3).normal(size=(4, 2, 3))
    phi[0, 0], phi[0, 1] = 0.0, 1e-13
    stacked = rotation_matrix(phi)
    assert stacked.shape == (4, 2, 3, 3)
    expected = Rotation.from_rotvec(phi.reshape(-1, 3)).as_matrix().reshape(4, 2, 3, 3)
    assert np.abs(stacked - expected).max() <= 1e-15 * 4
    assert np.array_equal(rotation_matrix(phi[2, 1]), stacked[2, 1])
