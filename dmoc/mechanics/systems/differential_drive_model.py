"""A differential-drive robot with its wheel angles as coordinates, a first-stage example
system in SI units: the Lagrangian of the body and the two wheels, three constraint
one-forms (27) (no side slip, each wheel rolling without slipping) and the two wheel
torques as controls.
"""

import casadi as ca

from ..._util import checks
from ..bodies import Body, heading_axes, rectangle, segment
from ..system import MechanicalSystem


def differential_drive(mass=10.0, yaw_inertia=0.5, wheel_inertia=0.01, wheel_radius=0.1,
                       half_track=0.25):
    """A differential-drive robot, as a MechanicalSystem (n=5, m=3, n_u=2), in SI units.

    Parameters
    ----------
    mass : float
        Mass m > 0 of the robot (kg), its centre of mass on the wheel axle's midpoint.
    yaw_inertia : float
        Moment of inertia I > 0 of the robot about the vertical axis through the axle's
        midpoint (kg m^2).
    wheel_inertia : float
        Moment of inertia J > 0 of each wheel about its axle (kg m^2).
    wheel_radius : float
        Wheel radius r > 0 (m).
    half_track : float
        Half the distance w > 0 between the wheels (m).

    Returns
    -------
    MechanicalSystem
        q = (x, y, theta, phi_l, phi_r), shape (5,): the axle's midpoint, the heading and
        the left and right wheel angles; controls u = (tau_l, tau_r), shape (2,), the
        wheel torques, named "left_torque" and "right_torque". Its `units`: m, m, rad,
        rad, rad; N m, N m; time in s. Its `bodies`: the "chassis", a square of side 2w
        on the axle, and the "left wheel" and "right wheel", 2r long.

    Notes
    -----
    The wheels sit at (x, y) +- w (-sin theta, cos theta) (left +, right -) and roll
    along the heading, so with sigma = xdot cos theta + ydot sin theta:

        L(q, v) = m/2 (xdot^2 + ydot^2) + I/2 thetadot^2 + J/2 (phidot_l^2 + phidot_r^2),
        A(q) = [[-sin theta, cos theta,  0,  0,  0],     (no side slip)
                [ cos theta, sin theta, -w, -r,  0],     (sigma - w thetadot = r phidot_l)
                [ cos theta, sin theta,  w,  0, -r]],    (sigma + w thetadot = r phidot_r)
        f(q, v, u) = (0, 0, 0, tau_l, tau_r).

    The allowed velocities are spanned by the two wheel rates: the robot drives at
    r (phidot_l + phidot_r)/2 and turns at r (phidot_r - phidot_l)/(2 w).

    Examples
    --------
    >>> s = differential_drive()
    >>> (s.n, s.m, s.n_u, s.names)
    (5, 3, 2, ('x', 'y', 'theta', 'phi_l', 'phi_r'))
    """
    m = checks.positive_float("mass", mass)
    I = checks.positive_float("yaw_inertia", yaw_inertia)
    J = checks.positive_float("wheel_inertia", wheel_inertia)
    r = checks.positive_float("wheel_radius", wheel_radius)
    w = checks.positive_float("half_track", half_track)

    def lagrangian(q, v):
        return m / 2 * (v[0] ** 2 + v[1] ** 2) + I / 2 * v[2] ** 2 + J / 2 * (v[3] ** 2 + v[4] ** 2)

    def constraints(q):
        c, s = ca.cos(q[2]), ca.sin(q[2])
        return ca.vertcat(ca.horzcat(-s, c, 0, 0, 0),
                          ca.horzcat(c, s, -w, -r, 0),
                          ca.horzcat(c, s, w, 0, -r))

    def force(q, v, u):
        return ca.vertcat(0, 0, 0, u[0], u[1])

    def wheel(side):
        def outline(q):
            n = heading_axes(q[2])[1]
            return segment(q[:2] + side * w * n, q[2], 2 * r)
        return outline

    return MechanicalSystem(lagrangian, 5, constraints=constraints, force=force, n_u=2,
                            names=("x", "y", "theta", "phi_l", "phi_r"),
                            control_names=("left_torque", "right_torque"),
                            bodies=(Body("chassis", lambda q: rectangle(q[:2], q[2], 2 * w, 2 * w)),
                                    Body("left wheel", wheel(1), closed=False, color="k"),
                                    Body("right wheel", wheel(-1), closed=False, color="k")),
                            units={"t": "s", "q": ("m", "m", "rad", "rad", "rad"),
                                   "u": ("N m", "N m")})
