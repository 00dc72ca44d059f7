"""The vertical rolling disk, a first-stage example system for the pipeline: its
Lagrangian, two constraint one-forms (27) omega^1 = dx - R cos(phi) dtheta and
omega^2 = dy - R sin(phi) dtheta (rolling without slipping), rolling and steering torques,
and the exact unforced solution used as a test oracle for the discrete principles (46)/(47).
"""

import casadi as ca
import numpy as np

from ..._util import checks
from ..bodies import Body, rectangle
from ..system import MechanicalSystem
from .knife_edge_model import _check_velocity, _sinc, _times


def rolling_disk(mass=1.0, radius=1.0, roll_inertia=None, steer_inertia=None):
    """Vertical disk rolling without slipping on a plane, as a MechanicalSystem (n=4, m=2, n_u=2).

    Parameters
    ----------
    mass : float
        Mass m > 0 of the disk.
    radius : float
        Radius R > 0.
    roll_inertia : float, optional
        Moment of inertia I > 0 about the disk axle; default m R^2 / 2 (uniform thin disk).
    steer_inertia : float, optional
        Moment of inertia J > 0 about the vertical axis; default m R^2 / 4.

    Returns
    -------
    MechanicalSystem
        q = (x, y, theta, phi), shape (4,), with theta the rolling angle and phi the
        heading; controls u = (u0, u1), shape (2,), named "roll_torque" and
        "steer_torque". Its `units` (for plots): m, m, rad, rad; N m, N m; time in s. Its
        `bodies`, seen from above: the "disk" (2R long, R/4 thick, along the heading) and
        a "rim mark" on its rim, moving along it as the disk rolls.

    Notes
    -----
    Following docs/theory.md and [1]_:

        L(q, v) = m/2 (xdot^2 + ydot^2) + I/2 thetadot^2 + J/2 phidot^2,
        A(q) = [[1, 0, -R cos(phi), 0], [0, 1, -R sin(phi), 0]],
        f(q, v, u) = (0, 0, u0, u1),

    u0 a rolling torque and u1 a steering torque.

    References
    ----------
    .. [1] A. M. Bloch, Nonholonomic Mechanics and Control, Springer, 2003.

    Examples
    --------
    >>> s = rolling_disk(mass=2.0, radius=0.5)
    >>> (s.n, s.m, s.n_u, s.names)
    (4, 2, 2, ('x', 'y', 'theta', 'phi'))
    """
    m = checks.positive_float("mass", mass)
    R = checks.positive_float("radius", radius)
    I = m * R**2 / 2 if roll_inertia is None else roll_inertia
    J = m * R**2 / 4 if steer_inertia is None else steer_inertia
    I, J = checks.positive_float("roll_inertia", I), checks.positive_float("steer_inertia", J)

    def lagrangian(q, v):
        return m / 2 * (v[0] ** 2 + v[1] ** 2) + I / 2 * v[2] ** 2 + J / 2 * v[3] ** 2

    def constraints(q):
        return ca.vertcat(ca.horzcat(1, 0, -R * ca.cos(q[3]), 0),
                          ca.horzcat(0, 1, -R * ca.sin(q[3]), 0))

    def force(q, v, u):
        return ca.vertcat(0, 0, u[0], u[1])

    def disk(q):
        return rectangle(q[:2], q[3], 2 * R, R / 4)

    def rim_mark(q):
        return q[None, :2] - R * np.sin(q[2]) * np.array([[np.cos(q[3]), np.sin(q[3])]])

    return MechanicalSystem(lagrangian, 4, constraints=constraints, force=force, n_u=2,
                            names=("x", "y", "theta", "phi"),
                            control_names=("roll_torque", "steer_torque"),
                            units={"t": "s", "q": ("m", "m", "rad", "rad"), "u": ("N m", "N m")},
                            bodies=(Body("disk", disk, color="goldenrod"),
                                    Body("rim mark", rim_mark, color="C3")))


def rolling_disk_solution(t, q0, v0, *, radius=1.0):
    """Exact solution of the unforced vertical rolling disk.

    Parameters
    ----------
    t : float or array_like, shape (N,)
        Times (t = 0 is the initial time).
    q0 : array_like, shape (4,)
        Initial configuration (x0, y0, theta0, phi0).
    v0 : array_like, shape (4,)
        Initial velocity; it must satisfy xdot = R cos(phi0) thetadot, ydot = R sin(phi0) thetadot.
    radius : float
        Radius R > 0; mass and inertias cancel out of the unforced motion.

    Returns
    -------
    q, v : ndarray, shape (N, 4)
        Configurations and velocities at the times `t` (N = 1 for scalar `t`).

    Notes
    -----
    The Lagrange-d'Alembert equations [1]_ m xddot = lam1, m yddot = lam2,
    I thetaddot = -R (cos(phi) lam1 + sin(phi) lam2), J phiddot = 0 with the constraints give
    (I + m R^2) thetaddot = 0, so thetadot = Omega and phidot = w are constant:
    theta = theta0 + Omega t, phi = phi0 + w t and, for w != 0,

        x = x0 + R Omega / w (sin(phi) - sin(phi0)),   y = y0 - R Omega / w (cos(phi) - cos(phi0)),

    a circle of radius |R Omega / w|; for w = 0 the straight line
    (x, y) = (x0, y0) + R Omega t (cos(phi0), sin(phi0)). The code writes both as
    R Omega t S(w t / 2) (cos(phi_m), sin(phi_m)), phi_m = phi0 + w t / 2, S(z) = sin(z)/z,
    valid for every w without cancellation. The energy (m R^2 + I) Omega^2 / 2 + J w^2 / 2
    is conserved.

    References
    ----------
    .. [1] A. M. Bloch, Nonholonomic Mechanics and Control, Springer, 2003.

    Examples
    --------
    >>> q, v = rolling_disk_solution(np.pi, [0, 0, 0, 0], [1, 0, 1, 1])
    >>> np.round(q, 12) + 0.0   # half a unit circle
    array([[0.        , 2.        , 3.14159265, 3.14159265]])
    """
    t = _times(t)
    R = checks.positive_float("radius", radius)
    q0 = checks.array("q0", q0, (4,))
    v0 = checks.array("v0", v0, (4,))
    roll, w = v0[2], v0[3]
    heading = np.array([np.cos(q0[3]), np.sin(q0[3])])
    _check_velocity(v0[:2] - R * roll * heading, max(np.abs(v0[:2]).max(), abs(R * roll)),
                    "the constraints xdot = R cos(phi0) thetadot, ydot = R sin(phi0) thetadot")
    phi, phi_m = q0[3] + w * t, q0[3] + w * t / 2
    arc = R * roll * t * _sinc(w * t / 2)
    q = np.column_stack([q0[0] + arc * np.cos(phi_m), q0[1] + arc * np.sin(phi_m),
                         q0[2] + roll * t, phi])
    v = np.column_stack([R * roll * np.cos(phi), R * roll * np.sin(phi),
                         np.full_like(t, roll), np.full_like(t, w)])
    return q, v
