"""Point vortices in the plane, a first-stage example system with a Lagrangian linear in the
velocities (degenerate: dL/dv depends on q only), no constraints, and the exact rigid
rotation of a pair as an oracle for the discrete principles (46)/(47) (docs/degenerate.md).
"""

import casadi as ca
import numpy as np

from ..._util import checks
from ..bodies import Body
from ..system import MechanicalSystem
from .knife_edge_model import _sinc, _times
from ...errors import InputError


def point_vortices(circulations):
    """Point vortices of the given circulations, as a MechanicalSystem (n = 2 K, m = 0).

    Parameters
    ----------
    circulations : sequence of float
        Circulations Gamma_1 ... Gamma_K, each nonzero; positive ones turn counter-clockwise.

    Returns
    -------
    MechanicalSystem
        q = (x_1, y_1, x_2, y_2, ...), shape (2 K,); no constraints, no controls. Its
        `units` (for plots): positions in m, time in s (circulations in m^2/s). Its
        `bodies`: "vortex 1", "vortex 2", ..., points at (x_i, y_i).

    Notes
    -----
    Following [1]_ and [2]_:

        L(q, v) = sum_i Gamma_i/2 (x_i ydot_i - y_i xdot_i) - H(q),
        H(q) = 1/(4 pi) sum_{i<j} Gamma_i Gamma_j log |r_i - r_j|^2,   r_i = (x_i, y_i).

    L is linear in v: p = dL/dv = (-Gamma_i y_i/2, Gamma_i x_i/2)_i is a function of q
    alone, never inverted. The Euler-Lagrange equations are Gamma_i xdot_i = -dH/dy_i,
    Gamma_i ydot_i = dH/dx_i, that is the Biot-Savart law

        rdot_i = sum_{j != i} Gamma_j/(2 pi) J (r_i - r_j)/|r_i - r_j|^2,   J = [[0, -1], [1, 0]].

    The sign and the factor of H are chosen for this: H is minus the Kirchhoff-Routh
    function W = -1/(4 pi) sum Gamma_i Gamma_j log |r_ij|^2 of the convention
    Gamma_i xdot_i = dW/dy_i, because this L carries the opposite symplectic sign. A vortex
    of positive circulation then turns counter-clockwise, and a pair at distance d turns
    about its centre of vorticity at Omega = (Gamma_1 + Gamma_2)/(2 pi d^2)
    (`point_vortices_solution`).

    References
    ----------
    .. [1] P. K. Newton, The N-Vortex Problem, Springer, 2001.
    .. [2] C. W. Rowley and J. E. Marsden, Variational integrators for degenerate
       Lagrangians, with application to point vortices, Proc. IEEE CDC 2002.

    Examples
    --------
    >>> s = point_vortices([1.0, -0.5])
    >>> (s.n, s.m, s.n_u, s.names)
    (4, 0, 0, ('x_1', 'y_1', 'x_2', 'y_2'))
    """
    gamma = _circulations(circulations)
    K = len(gamma)

    def lagrangian(q, v):
        kinetic = sum(g / 2 * (q[2 * i] * v[2 * i + 1] - q[2 * i + 1] * v[2 * i])
                      for i, g in enumerate(gamma))
        H = sum(gamma[i] * gamma[j] / (4 * np.pi)
                * ca.log((q[2 * i] - q[2 * j]) ** 2 + (q[2 * i + 1] - q[2 * j + 1]) ** 2)
                for i in range(K) for j in range(i + 1, K))
        return kinetic - H

    names = tuple(f"{axis}_{i + 1}" for i in range(K) for axis in ("x", "y"))
    bodies = tuple(Body(f"vortex {i + 1}", lambda q, i=i: q[None, 2 * i:2 * i + 2],
                        color=f"C{i % 10}") for i in range(K))
    return MechanicalSystem(lagrangian, 2 * K, names=names, units={"t": "s", "q": ("m",) * (2 * K)},
                            bodies=bodies)


def point_vortices_solution(t, q0, circulations):
    """Exact motion of a pair of point vortices of :func:`point_vortices`.

    Parameters
    ----------
    t : float or array_like, shape (N,)
        Times (t = 0 is the initial time).
    q0 : array_like, shape (4,)
        Initial positions (x_1, y_1, x_2, y_2) of two distinct vortices.
    circulations : pair of float
        (Gamma_1, Gamma_2), both nonzero.

    Returns
    -------
    q, v : ndarray, shape (N, 4)
        Positions and velocities at the times `t` (N = 1 for scalar `t`).

    Notes
    -----
    The separation r = r_1 - r_2 obeys rdot = Omega J r with Omega = (Gamma_1 + Gamma_2)
    /(2 pi d^2), d = |r| constant, so r(t) = R(Omega t) r(0), R the rotation. Integrating
    rdot_1 = Gamma_2/(2 pi d^2) J r and rdot_2 = -Gamma_1/(2 pi d^2) J r with
    (R(Omega t) - I)/Omega = t S(Omega t/2) R(Omega t/2) J, S(z) = sin(z)/z:

        r_1(t) = r_1(0) + Gamma_2/(2 pi d^2) t S(Omega t/2) R(Omega t/2) J r(0),
        r_2(t) = r_2(0) - Gamma_1/(2 pi d^2) t S(Omega t/2) R(Omega t/2) J r(0),

    valid for every pair: a rigid rotation at Omega about the fixed centre of vorticity
    (Gamma_1 r_1 + Gamma_2 r_2)/(Gamma_1 + Gamma_2), and for Gamma_1 = -Gamma_2 a uniform
    translation at speed |Gamma_2|/(2 pi d).

    Examples
    --------
    >>> q, v = point_vortices_solution(2 * np.pi, [1, 0, -1, 0], [np.pi, np.pi])
    >>> np.round(q, 12) + 0.0   # Omega = 1/4: a quarter turn about the origin
    array([[ 0.,  1.,  0., -1.]])
    """
    t = _times(t)
    gamma = _circulations(circulations)
    if len(gamma) != 2:
        raise InputError(f"`circulations` must be a pair (Gamma_1, Gamma_2) for the exact "
                         f"solution; got {len(gamma)} vortices.")
    q0 = checks.array("q0", q0, (4,))
    r0 = q0[:2] - q0[2:]
    d2 = float(r0 @ r0)
    if d2 == 0.0:
        raise InputError("`q0` must place the two vortices at distinct points.")
    Omega = (gamma[0] + gamma[1]) / (2 * np.pi * d2)
    half = Omega * t / 2
    Jr0 = np.array([-r0[1], r0[0]])
    rotated = np.column_stack([np.cos(half) * Jr0[0] - np.sin(half) * Jr0[1],
                               np.sin(half) * Jr0[0] + np.cos(half) * Jr0[1]])
    sweep = (t * _sinc(half))[:, None] * rotated / (2 * np.pi * d2)
    r = r0 + (gamma[0] + gamma[1]) * sweep           # R(Omega t) r(0)
    Jr = np.column_stack([-r[:, 1], r[:, 0]]) / (2 * np.pi * d2)
    q = np.column_stack([q0[:2] + gamma[1] * sweep, q0[2:] - gamma[0] * sweep])
    v = np.column_stack([gamma[1] * Jr, -gamma[0] * Jr])
    return q, v


def _circulations(circulations):
    """The circulations as a tuple of nonzero floats, or a ValueError naming them."""
    if np.ndim(circulations) != 1 or len(circulations) == 0:
        raise InputError(f"`circulations` must be a non-empty sequence of numbers; got {circulations!r}.")
    gamma = tuple(checks.finite_float("circulations", g) for g in circulations)
    if 0.0 in gamma:
        raise InputError(f"`circulations` must be nonzero (a vortex of zero circulation has no "
                         f"dynamics of its own); got {gamma}.")
    return gamma
