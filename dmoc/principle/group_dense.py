"""Dense output of a RotationTrajectory (the principle stage's solution on SO(3) x R^n_x
between the knots), behind `RotationTrajectory.sample`.

The rotation follows the step's own increment: on step k, with c = (t - t_k)/h in [0, 1],

    R(t) = R_k cay(c f_k),

f_k the Cayley coordinates of F_k = R_k^T R_{k+1} (the unknowns of the group step
residual). c f_k keeps the axis of f_k, so R(t) runs along the geodesic from R_k to
R_k F_k (the one-parameter subgroup R_k exp(s log F_k)), at the angle 2 atan(c |f_k|/2)
instead of the uniform c 2 atan(|f_k|/2): the two differ by (2/3)(|f_k|/2)^3 (c - c^3),
O(h^3), below the O(h^2) of the midpoint step's knots. cay needs no logarithm (f_k is
stored) and is a rotation for every argument, so every R(t) is a product of two
rotations, orthogonal to round-off. The body angular velocity is Omega(t) =
vee(R(t)^T R'(t)) = f_k / (h (1 + c^2 |f_k|^2 / 4)). x(t) is the chord between x_k and
x_{k+1} and x'(t) its slope; (Pi, p_x) are linear between the knots and u is held on
the step (`dense`). At the knots every value is the stored one.
"""

import functools
from typing import NamedTuple

import casadi as ca
import numpy as np

from ..mechanics.rotations import cayley, vee
from . import dense


class RotationSample(NamedTuple):
    """The dense motion on SO(3) x R^n_x at K times (`RotationTrajectory.sample`); for a
    scalar time t is a float and every array loses its first axis.

    Attributes
    ----------
    t : ndarray, shape (K,)
    R : ndarray, shape (K, 3, 3)
        The rotations R(t) (body to space).
    x : ndarray, shape (K, n_x)
        The vector coordinates.
    v : ndarray, shape (K, 3 + n_x)
        The velocity (Omega(t), x'(t)): the body angular velocity vee(R^T R') and x'.
    p : ndarray, shape (K, 3 + n_x)
        The momentum (Pi(t), p_x(t)).
    u : ndarray, shape (K, n_u)
        The control.
    """

    t: np.ndarray
    R: np.ndarray
    x: np.ndarray
    v: np.ndarray
    p: np.ndarray
    u: np.ndarray


@functools.cache
def _increment():
    """The Function (f, c, h) -> (cay(c f), vee(cay(c f)^T d/dc cay(c f)) / h): the
    rotation along the step's increment at step time c and the body angular velocity
    there (by CasADi's derivative of `cayley`)."""
    f, c, h = ca.SX.sym("f", 3), ca.SX.sym("c"), ca.SX.sym("h")
    F = cayley(c * f)
    dF = ca.reshape(ca.jacobian(ca.vec(F), c), 3, 3)
    return ca.Function("rotation_increment", [f, c, h], [F, vee(ca.mtimes(F.T, dF)) / h])


def rotations(traj, k, c):
    """(R, Omega) at step times c of steps k, shapes (K, 3, 3) and (K, 3): R_k cay(c f_k),
    the stored R_k where c = 0 and R_{k+1} where c = 1."""
    K = len(k)
    if not K:                       # an empty sample (CasADi maps over at least one time)
        return np.zeros((0, 3, 3)), np.zeros((0, 3))
    F, omega = _increment().map(K)(traj.f[k, :3].T, c[None, :], traj.h)
    F = np.array(F).reshape(3, 3, K, order="F").transpose(2, 0, 1)   # CasADi is column-major
    R = np.einsum("kij,kjl->kil", traj.R[k], F)
    R[c == 0.0], R[c == 1.0] = traj.R[k[c == 0.0]], traj.R[k[c == 1.0] + 1]
    return R, np.array(omega).T.reshape(K, 3)


def sample(traj, t):
    """The `RotationSample` of `traj` at times `t` (a scalar, or a 1-D array of K times)."""
    times, k, c = dense.step_times(traj, t)
    R, omega = rotations(traj, k, c)
    x = (1 - c)[:, None] * traj.x[k] + c[:, None] * traj.x[k + 1]
    v = np.hstack([omega, (traj.x[k + 1] - traj.x[k]) / traj.h])
    values = RotationSample(times, R, x, v, dense.momenta(traj, k, c), dense.controls(traj, k, c))
    return RotationSample(float(times[0]), *(a[0] for a in values[1:])) if np.ndim(t) == 0 else values
