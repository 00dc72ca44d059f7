"""The knife edge (Chaplygin sleigh blade) on an inclined plane, a first-stage example
system for the pipeline: its Lagrangian, one constraint one-form omega = -sin(theta) dx
+ cos(theta) dy (27), a control force, and the exact solution of the unforced
Lagrange-d'Alembert equations used as a test oracle for the discrete principles (46)/(47).
"""

import casadi as ca
import numpy as np

from ..._util import checks
from ..bodies import Body, heading_axes
from ..given import constraint_violation_tolerance
from ..system import MechanicalSystem
from ...errors import InputError, InputTypeError

_SERIES_BELOW = 0.1  # |x| below which (x - sin x) / x^3 is summed as a series


def knife_edge(mass=1.0, inertia=1.0, incline=0.0, gravity=9.81):
    """Knife edge on a plane inclined by `incline`, as a MechanicalSystem (n=3, m=1, n_u=2).

    Parameters
    ----------
    mass : float
        Mass m > 0 of the blade.
    inertia : float
        Moment of inertia J > 0 about the vertical axis through the contact point.
    incline : float
        Inclination alpha of the plane (radians); gravity pulls towards negative x.
    gravity : float
        Gravitational acceleration g.

    Returns
    -------
    MechanicalSystem
        q = (x, y, theta), shape (3,); controls u = (u0, u1), shape (2,), named "force"
        and "torque". Its `units` (for plots): m, m, rad; N, N m; time in s. Its body
        (`bodies`): the "blade", BLADE long, pointed at its leading end, centred on the
        contact point (x, y).

    Notes
    -----
    With a = g sin(alpha) (docs/theory.md and [1]_):

        L(q, v) = m/2 (xdot^2 + ydot^2) + J/2 thetadot^2 - m a x,
        A(q) = [-sin(theta), cos(theta), 0]      (no sideways slip),
        f(q, v, u) = (u0 cos(theta), u0 sin(theta), u1),

    u0 being a force along the blade direction (cos(theta), sin(theta)) and u1 a torque.

    References
    ----------
    .. [1] A. M. Bloch, Nonholonomic Mechanics and Control, Springer, 2003.

    Examples
    --------
    >>> s = knife_edge(incline=0.2)
    >>> (s.n, s.m, s.n_u, s.names)
    (3, 1, 2, ('x', 'y', 'theta'))
    """
    m = checks.positive_float("mass", mass)
    J = checks.positive_float("inertia", inertia)
    a = checks.finite_float("gravity", gravity) * np.sin(checks.finite_float("incline", incline))

    def lagrangian(q, v):
        return m / 2 * (v[0] ** 2 + v[1] ** 2) + J / 2 * v[2] ** 2 - m * a * q[0]

    def constraints(q):
        return ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0)

    def force(q, v, u):
        return ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1])

    return MechanicalSystem(lagrangian, 3, constraints=constraints, force=force, n_u=2,
                            names=("x", "y", "theta"), control_names=("force", "torque"),
                            units={"t": "s", "q": ("m", "m", "rad"), "u": ("N", "N m")},
                            bodies=(Body("blade", _blade, color="0.2"),))


BLADE = 0.3     # m, the length of the drawn blade


def _blade(q):
    """The outline of the blade at q = (x, y, theta), shape (5, 2): a thin strip pointed
    along the heading."""
    e, n = heading_axes(q[2])
    along, across = np.array([-0.5, 0.35, 0.5, 0.35, -0.5]), np.array([-1, -1, 0, 1, 1])
    return q[:2] + BLADE * np.outer(along, e) + 0.03 * BLADE * np.outer(across, n)


def knife_edge_solution(t, q0, v0, *, incline=0.0, gravity=9.81):
    """Exact solution of the unforced knife edge on an inclined plane.

    Parameters
    ----------
    t : float or array_like, shape (N,)
        Times (t = 0 is the initial time).
    q0 : array_like, shape (3,)
        Initial configuration (x0, y0, theta0).
    v0 : array_like, shape (3,)
        Initial velocity; it must satisfy the constraint -sin(theta0) xdot + cos(theta0) ydot = 0.
    incline, gravity : float
        As in :func:`knife_edge`; mass and inertia cancel out of the unforced motion.

    Returns
    -------
    q, v : ndarray, shape (N, 3)
        Configurations and velocities at the times `t` (N = 1 for scalar `t`).

    Notes
    -----
    The Lagrange-d'Alembert equations [1]_ m xddot + m a = -lam sin(theta),
    m yddot = lam cos(theta), J thetaddot = 0, with a = g sin(alpha), give theta = theta0 + w t
    and, for the speed sigma along the blade (xdot = sigma cos(theta), ydot = sigma sin(theta)),
    sigma' = -a cos(theta). With s = sin, c = cos, for w != 0:

        sigma = sigma0 - a/w (s(theta) - s(theta0)),
        x = x0 + sigma0/w (s(theta) - s(theta0)) - a/(2 w^2) (s(theta) - s(theta0))^2,
        y = y0 + sigma0/w (c(theta0) - c(theta))
              - a/w [t/2 - (s(2 theta) - s(2 theta0))/(4 w) - s(theta0) (c(theta0) - c(theta))/w].

    For a = 0 the contact point runs on a circle of radius |sigma0/w|. For w = 0 the blade
    moves on a straight line, uniformly accelerated: sigma = sigma0 - a c0 t,
    (x, y) = (x0, y0) + (sigma0 t - a c0 t^2/2) (c0, s0).

    These formulas lose all accuracy for small |w t| (they subtract nearly equal numbers
    and divide by w^2). The code uses the equivalent forms, with Dt = w t, theta_m = theta0
    + Dt/2, S(z) = sin(z)/z and G(z) = (z - sin z)/z^3 (a series for small z):

        s(theta) - s(theta0) = w t c(theta_m) S(Dt/2),
        c(theta0) - c(theta) = w t s(theta_m) S(Dt/2),
        y-bracket / w = w t^3 s0^2 (G(Dt) - 2 G(2 Dt)) + t^2 s0 c0 (S(Dt)^2 - S(Dt/2)^2/2)
                        + 2 w t^3 c0^2 G(2 Dt),

    which hold for every w, including w = 0, to round-off. The energy
    m/2 sigma^2 + J/2 w^2 + m a x is conserved.

    References
    ----------
    .. [1] A. M. Bloch, Nonholonomic Mechanics and Control, Springer, 2003.

    Examples
    --------
    >>> q, v = knife_edge_solution([0.0, np.pi], [0, 0, 0], [1, 0, 1])
    >>> np.round(q[-1], 12) + 0.0   # half a unit circle
    array([0.        , 2.        , 3.14159265])
    """
    t = _times(t)
    q0 = checks.array("q0", q0, (3,))
    v0 = checks.array("v0", v0, (3,))
    a = checks.finite_float("gravity", gravity) * np.sin(checks.finite_float("incline", incline))
    s0, c0 = np.sin(q0[2]), np.cos(q0[2])
    _check_velocity(-s0 * v0[0] + c0 * v0[1], np.abs(v0[:2]).max(),
                    "the constraint -sin(theta0) xdot + cos(theta0) ydot = 0")
    w, sigma0 = v0[2], c0 * v0[0] + s0 * v0[1]
    turn = w * t
    theta, theta_m = q0[2] + turn, q0[2] + turn / 2
    int_cos = t * np.cos(theta_m) * _sinc(turn / 2)  # int_0^t cos(theta)
    int_sin = t * np.sin(theta_m) * _sinc(turn / 2)  # int_0^t sin(theta)
    int_y = (w * t**3 * s0**2 * (_g(turn) - 2 * _g(2 * turn))  # int_0^t int_cos(s) sin(theta(s)) ds
             + t**2 * s0 * c0 * (_sinc(turn) ** 2 - _sinc(turn / 2) ** 2 / 2)
             + 2 * w * t**3 * c0**2 * _g(2 * turn))
    sigma = sigma0 - a * int_cos
    q = np.column_stack([q0[0] + sigma0 * int_cos - a * int_cos**2 / 2,
                         q0[1] + sigma0 * int_sin - a * int_y, theta])
    v = np.column_stack([sigma * np.cos(theta), sigma * np.sin(theta), np.full_like(t, w)])
    return q, v


def _times(t):
    """Return `t` as a finite 1-D float array (a scalar becomes shape (1,))."""
    try:
        out = np.atleast_1d(np.asarray(t, dtype=float))
    except (TypeError, ValueError):
        raise InputTypeError("`t` must be a real number or a 1-D array of them; "
                             f"got {type(t).__name__}.") from None
    if out.ndim != 1:
        raise InputError(f"`t` must be a scalar or a 1-D array; got shape {out.shape}.")
    if not np.all(np.isfinite(out)):
        raise InputError("`t` must be finite.")
    return out


def _check_velocity(residual, scale, what):
    """Raise ValueError naming `v0` if |residual| exceeds the library's tolerance on A(q) v."""
    residual = float(np.max(np.abs(residual)))
    if residual > constraint_violation_tolerance(float(scale)):
        raise InputError(f"`v0` must satisfy {what}; the residual is {residual:.3e}. "
                         "Hint: choose v0 in ker A(q0).")


def _sinc(x):
    """sin(x) / x, equal to 1 at x = 0."""
    return np.sinc(x / np.pi)


def _g(x):
    """(x - sin x) / x^3, by its Taylor series for |x| < 0.1 (no cancellation)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < _SERIES_BELOW
    xs = np.where(small, 1.0, x)
    x2 = np.where(small, x, 0.0) ** 2
    series = 1 / 6 - x2 / 120 * (1 - x2 / 42 * (1 - x2 / 72 * (1 - x2 / 110)))
    return np.where(small, series, (xs - np.sin(xs)) / xs**3)
