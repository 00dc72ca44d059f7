"""Hard problems of issue 40, kept as test fixtures (and read by benchmarks/verdict.py --hard and warm_options.py):
a truck backing a trailer into a bay between two parked trailers (SI units, free final
time, bounds, a steering-rate row, a speed row, a jack-knife row, discs and a road edge),
and the rolling disk to a goal with control bounds and a free final time."""

import casadi as ca
import numpy as np

import dmoc

TRUCK_MASS, TRAILER_MASS = 8000.0, 3000.0       # kg
TRUCK_YAW, TRAILER_YAW = 4.0e4, 3.0e4           # kg m^2 about the axles
STEERING_INERTIA = 200.0                        # kg m^2
WHEELBASE, HITCH = 4.0, 6.0                     # m: truck axle to front wheel; hitch (on the
                                                # truck's rear axle) to the trailer's axle
STEERING, STEERING_RATE, SPEED = 0.6, 0.4, 3.0  # rad, rad/s, m/s
JACK_KNIFE = np.pi / 3                          # rad: |theta1 - theta0|
FORCE, TORQUE = 2.0e4, 2.0e3                    # N, N m
PARKED = ((-4.5, -3.0), (-4.5, -9.0), (4.5, -3.0), (4.5, -9.0))   # m: disc centres
RADIUS = 2.6                                    # m: a parked trailer's half width with margins
ROAD_EDGE = 12.0                                # m: the far edge of the road, y <= it


def truck_with_trailer():
    """A truck (rear-axle midpoint (x, y), heading theta0, steering delta) towing a
    trailer (heading theta1) hitched on the truck's rear axle, every centre of mass on its
    axle: a MechanicalSystem with n = 5, three rolling rows (truck rear axle, front wheel,
    trailer axle), controls (F, tau): the drive force along theta0 and the steering torque."""
    def lagrangian(q, v):
        trailer_axle = ca.vertcat(v[0] + HITCH * ca.sin(q[4]) * v[4], v[1] - HITCH * ca.cos(q[4]) * v[4])
        return (TRUCK_MASS / 2 * (v[0] ** 2 + v[1] ** 2) + TRUCK_YAW / 2 * v[2] ** 2
                + STEERING_INERTIA / 2 * v[3] ** 2 + TRAILER_MASS / 2 * ca.sumsqr(trailer_axle)
                + TRAILER_YAW / 2 * v[4] ** 2)

    def constraints(q):
        front = q[2] + q[3]
        return ca.vertcat(ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0, 0, 0),
                          ca.horzcat(-ca.sin(front), ca.cos(front), WHEELBASE * ca.cos(q[3]), 0, 0),
                          ca.horzcat(-ca.sin(q[4]), ca.cos(q[4]), 0, 0, -HITCH))

    def force(q, v, u):
        return ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), 0, u[1], 0)

    return dmoc.MechanicalSystem(lagrangian, 5, constraints=constraints, force=force, n_u=2,
                                 names=("x", "y", "theta0", "delta", "theta1"))


def _kept_out(q, v, u):
    """Rows <= 0: the steering rate, the speed, the jack-knife, four trailer points out of
    the parked trailers' discs, the truck's front on the road."""
    return ca.vertcat(v[3] ** 2 - STEERING_RATE ** 2, _kept_out_but_rate(q, v, u))


def _kept_out_but_rate(q, v, u):
    """The rows of `_kept_out` after the first (the steering rate): speed, jack-knife,
    discs, road edge."""
    heading = ca.vertcat(ca.cos(q[4]), ca.sin(q[4]))
    points = [q[:2] - s * HITCH * heading for s in (0.0, 0.5, 1.0, 1.3)]
    discs = [RADIUS ** 2 - ca.sumsqr(point - ca.DM(centre)) for point in points for centre in PARKED]
    front = q[1] + WHEELBASE * ca.sin(q[2])
    return ca.vertcat(v[0] ** 2 + v[1] ** 2 - SPEED ** 2, (q[4] - q[2]) ** 2 - JACK_KNIFE ** 2, *discs,
                      front - ROAD_EDGE)


def truck_bay(steps=30, rule="midpoint", rate="path"):
    """Back the trailer into the bay: from rest at (10, 6) heading +x to rest with the
    truck's axle at (0, 1), truck and trailer heading +y (the trailer in the bay between
    the parked trailers), free final time in [8, 120] s; cost int (F/F)^2 + (tau/T)^2 + 0.1 dt.
    `rate`: the steering rate limit as the path row v_delta^2 - 0.4^2 <= 0 ("path") or as
    the velocity bound |v_delta| <= 0.4 ("bound")."""
    disc = dmoc.discretize(truck_with_trailer(), 30.0 / steps, rule)
    limits = ({"path_constraints": _kept_out} if rate == "path" else
              {"path_constraints": _kept_out_but_rate,
               "velocity_bounds": ([None, None, None, -STEERING_RATE, None],
                                   [None, None, None, STEERING_RATE, None])})
    return dmoc.OptimalControlProblem(
        disc, steps, q_start=[10.0, 6.0, 0.0, 0.0, 0.0], q_goal=[0.0, 1.0, np.pi / 2, 0.0, np.pi / 2],
        running_cost=lambda q, v, u: (u[0] / FORCE) ** 2 + (u[1] / TORQUE) ** 2 + 0.1,
        control_bounds=([-FORCE, -TORQUE], [FORCE, TORQUE]), **limits,
        state_bounds=([None, None, None, -STEERING, None], [None, ROAD_EDGE, None, STEERING, None]),
        duration=(8.0, 120.0))


def bounded_disk(steps=20, rule="midpoint"):
    """The rolling disk (m = R = 1) from rest at 0 to rest at (1, 1, free, pi/2) with
    |u_i| <= 1 and a free final time in [0.5, 20], cost int |u|^2/10 + 1 dt."""
    disc = dmoc.discretize(dmoc.systems.rolling_disk(mass=1.0, radius=1.0), 4.0 / steps, rule)
    return dmoc.OptimalControlProblem(
        disc, steps, q_start=[0.0, 0.0, 0.0, 0.0], q_goal=[1.0, 1.0, None, np.pi / 2],
        running_cost=lambda q, v, u: ca.sumsqr(u) / 10 + 1.0,
        control_bounds=([-1.0, -1.0], [1.0, 1.0]), duration=(0.5, 20.0))
