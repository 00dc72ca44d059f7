"""The rotation group SO(3), the configuration space of a rigid body (first stage of the
pipeline): the hat map R^3 -> so(3) and its inverse vee, the Cayley map cay: R^3 -> SO(3)
that writes a step's group increment F_k = R_k^T R_{k+1} in three coordinates [1]_, its
inverse and its half (the square root of cay(f)), the Bjorck-Bowie step that keeps products of rotations orthogonal [2]_, and the
row-major layout that carries a rotation matrix as a vector of 9 entries. The maps take and
return CasADi expressions (they evaluate numerically on DM or numpy input).

References
----------
.. [1] M. Kobilarov, J. E. Marsden, "Discrete geometric optimal control on Lie groups",
   IEEE Trans. Robotics 27 (2011) (the Cayley map on SO(3) and its use in DMOC).
.. [2] A. Bjorck, C. Bowie, "An iterative algorithm for computing the best estimate of an
   orthogonal matrix", SIAM J. Numer. Anal. 8 (1971) 358-364.
"""

import functools

import casadi as ca
import numpy as np

from .._util import checks
from ..errors import InputError

ORTHOGONALITY_TOLERANCE = 1e-10     # |R^T R - I| accepted of a rotation given by a user


def hat(w):
    """The skew matrix w^ of w, shape (3,) -> (3, 3), with w^ x = w x x."""
    return _fixed("hat", (3, 1), _hat)(w)


def vee(A):
    """The vector of the skew part of a (3, 3) matrix: vee(w^) = w; shape (3, 1)."""
    return _fixed("vee", (3, 3), _vee)(A)


def cayley(f):
    """The Cayley map cay(f) = (I - f^/2)^{-1} (I + f^/2) = I + 4/(4 + |f|^2) (f^ + f^2/2),
    shape (3,) -> (3, 3), a rotation for every f (Kobilarov & Marsden [1])."""
    return _fixed("cayley", (3, 1), _cayley)(f)


def cayley_inverse(F):
    """cay^{-1}(F) = 2 vee(F - F^T) / (1 + tr F), shape (3, 3) -> (3,); defined for
    rotations by less than pi."""
    return _fixed("cayley_inverse", (3, 3), _cayley_inverse)(F)


def cayley_half(f):
    """g = f / (1 + sqrt(1 + |f|^2/4)), shape (3,) -> (3,): the Cayley coordinates of the
    square root of cay(f), cay(g)^2 = cay(f), the rotation halfway along the geodesic from
    I to cay(f) (cay(f) turns by 2 atan(|f|/2) about f, so g turns by half of it about the
    same axis: |g|/2 = tan(atan(|f|/2)/2)); smooth in f."""
    return _fixed("cayley_half", (3, 1), _cayley_half)(f)


@functools.cache
def _fixed(name, shape, expression):
    """The SX Function of a fixed map of one argument of `shape`, made on first use and
    kept for the process (it holds no system's data). The maps above call it: on SX it is
    inlined, the same nodes as `expression` makes, at a tenth of the cost of making them
    from Python op by op (`cayley` on an SX: 27 against 270 us, each CasADi operation
    from Python paying its overload resolution); on numbers it evaluates (a DM); on MX
    it is a call node."""
    x = ca.SX.sym("x", *shape)
    return ca.Function(name, [x], [expression(x)])


def _hat(w):
    return ca.vertcat(ca.horzcat(0, -w[2], w[1]),
                      ca.horzcat(w[2], 0, -w[0]),
                      ca.horzcat(-w[1], w[0], 0))


def _vee(A):
    return 0.5 * ca.vertcat(A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1])


def _cayley(f):
    F = _hat(f)
    return ca.DM.eye(3) + 4 / (4 + ca.dot(f, f)) * (F + 0.5 * ca.mtimes(F, F))


def _cayley_inverse(F):
    return 4 * _vee(F) / (1 + ca.trace(F))


def _cayley_half(f):
    return f / (1 + ca.sqrt(1 + ca.dot(f, f) / 4))


def orthogonalized(R):
    """R (3 I - R^T R) / 2, one Newton step of the polar decomposition toward the nearest
    rotation (Bjorck & Bowie [2]): the identity on SO(3), it removes the round-off of a
    product of rotations, or an optimizer's violation of the rows that make R_k a
    rotation (of order |R^T R - I|^2 left), without moving R by more than it. `R` is a
    CasADi 3 x 3 matrix or a numpy stack of shape (..., 3, 3), each matrix stepped."""
    if isinstance(R, np.ndarray):
        return 0.5 * R @ (3 * np.eye(3) - np.swapaxes(R, -1, -2) @ R)
    return 0.5 * ca.mtimes(R, 3 * ca.DM.eye(3) - ca.mtimes(R.T, R))


def matrix_of(q):
    """The (3, 3) rotation whose rows, one after another, are the 9 entries of q."""
    return ca.reshape(q, 3, 3).T


def vector_of(R):
    """The 9 entries of the (3, 3) matrix R, row after row (the inverse of `matrix_of`)."""
    return ca.vec(R.T)


def split_configuration(q):
    """(R, x) of a configuration q = (the 9 entries of R row after row, x) of SO(3) x R^n_x."""
    return matrix_of(q[:9]), q[9:]


def joined_configuration(R, x):
    """The configuration vector (rows of R, x), the inverse of `split_configuration`."""
    return ca.vertcat(vector_of(R), x)


def as_rotation(name, value):
    """`value` checked to be a rotation matrix, shape (3, 3), R^T R = I to
    ORTHOGONALITY_TOLERANCE and det R = +1; returned as a float array."""
    R = checks.array(name, value, (3, 3))
    defect = float(np.abs(R.T @ R - np.eye(3)).max())
    if defect > ORTHOGONALITY_TOLERANCE or np.linalg.det(R) < 0:
        raise InputError(f"`{name}` must be a rotation matrix (R^T R = I to "
                         f"{ORTHOGONALITY_TOLERANCE:g}, det R = +1); got |R^T R - I| = "
                         f"{defect:.2e}, det R = {np.linalg.det(R):.6g}.")
    return R
