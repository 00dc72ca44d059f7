"""A car as a kinematic bicycle with the steering angle as a coordinate, a first-stage
example system in SI units: the Lagrangian of its body and steering, two constraint
one-forms (27) for the rear axle and the front wheel rolling without side slip, a drive
force and a steering torque.
"""

import casadi as ca

from ..._util import checks
from ..bodies import Body, heading_axes, rectangle, segment
from ..system import MechanicalSystem


def car(mass=1500.0, yaw_inertia=2500.0, steering_inertia=1.0, wheelbase=2.7, com_offset=0.0,
        steering_stiffness=0.0, steering_rest=0.0):
    """A bicycle-model car, as a MechanicalSystem (n=4, m=2, n_u=2), in SI units.

    Parameters
    ----------
    mass : float
        Mass m > 0 of the car (kg).
    yaw_inertia : float
        Moment of inertia I_z > 0 about the vertical axis through the centre of mass (kg m^2).
    steering_inertia : float
        Moment of inertia I_delta > 0 of the steering about its axis (kg m^2).
    wheelbase : float
        Distance l > 0 from the rear axle to the front wheel (m).
    com_offset : float
        Distance b >= 0 of the centre of mass ahead of the rear axle, along the heading (m).
    steering_stiffness, steering_rest : float
        A spring k/2 (delta - delta_0)^2 holding the steering at `steering_rest` (N m/rad,
        rad); k >= 0, 0 by default (no spring).

    Returns
    -------
    MechanicalSystem
        q = (x, y, theta, delta), shape (4,): the rear-axle midpoint, the heading and the
        steering angle; controls u = (F, tau), shape (2,), named "force" and
        "steering_torque". Its `units`: m, m, rad, rad; N, N m; time in s. Its `bodies`:
        the car's "body", a rectangle OVERHANG beyond both axles and WIDTH wide, and its
        "front wheel", WHEEL long, turned by the steering angle.

    Notes
    -----
    With (x_c, y_c) = (x + b cos theta, y + b sin theta) the centre of mass:

        L(q, v) = m/2 (xdot_c^2 + ydot_c^2) + I_z/2 thetadot^2 + I_delta/2 deltadot^2
                  - k/2 (delta - delta_0)^2,
        A(q) = [[-sin theta,           cos theta,           0,             0],
                [-sin(theta + delta),  cos(theta + delta),  l cos delta,   0]],
        f(q, v, u) = (F cos theta, F sin theta, 0, tau):

    the first row keeps the rear axle from slipping sideways, the second the front wheel
    (at (x, y) + l (cos theta, sin theta), rolling along theta + delta); F drives along the
    heading at the rear axle, tau turns the steering. Both one-forms are nonholonomic, so
    the car moves in a 2-dimensional set of velocities. With b > 0 the energy of the
    discrete flow drifts under every rule (docs/stages/simulate.md): nonholonomic
    integrators keep energy for reversible systems only [1]_.

    References
    ----------
    .. [1] K. Modin and O. Verdier, What makes nonholonomic integrators work?, Numer. Math.
       145 (2020) 405-435.

    Examples
    --------
    >>> s = car()
    >>> (s.n, s.m, s.n_u, s.names)
    (4, 2, 2, ('x', 'y', 'theta', 'delta'))
    """
    m = checks.positive_float("mass", mass)
    I_z = checks.positive_float("yaw_inertia", yaw_inertia)
    I_delta = checks.positive_float("steering_inertia", steering_inertia)
    l = checks.positive_float("wheelbase", wheelbase)
    b = checks.nonnegative_float("com_offset", com_offset)
    k = checks.nonnegative_float("steering_stiffness", steering_stiffness)
    delta_0 = checks.finite_float("steering_rest", steering_rest)

    def lagrangian(q, v):
        xdot_c = v[0] - b * ca.sin(q[2]) * v[2]
        ydot_c = v[1] + b * ca.cos(q[2]) * v[2]
        return (m / 2 * (xdot_c ** 2 + ydot_c ** 2) + I_z / 2 * v[2] ** 2 + I_delta / 2 * v[3] ** 2
                - k / 2 * (q[3] - delta_0) ** 2)

    def constraints(q):
        front = q[2] + q[3]
        return ca.vertcat(ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0, 0),
                          ca.horzcat(-ca.sin(front), ca.cos(front), l * ca.cos(q[3]), 0))

    def force(q, v, u):
        return ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), 0, u[1])

    def body(q):
        e = heading_axes(q[2])[0]
        return rectangle(q[:2] + l / 2 * e, q[2], l + 2 * OVERHANG, WIDTH)

    def front_wheel(q):
        return segment(q[:2] + l * heading_axes(q[2])[0], q[2] + q[3], WHEEL)

    return MechanicalSystem(lagrangian, 4, constraints=constraints, force=force, n_u=2,
                            names=("x", "y", "theta", "delta"),
                            control_names=("force", "steering_torque"),
                            units={"t": "s", "q": ("m", "m", "rad", "rad"), "u": ("N", "N m")},
                            bodies=(Body("body", body), Body("front wheel", front_wheel,
                                                             closed=False, color="k")))


OVERHANG, WIDTH, WHEEL = 0.9, 1.8, 0.65     # m: of the drawn car
