"""Ready-made DMOC problems on the built-in systems, shared by the examples, the
command-line demo and the benchmarks so that they all solve the same thing."""

import numpy as np

from ...discrete import discretize
from .problem import OptimalControlProblem
from ...mechanics.systems import car, knife_edge, rolling_disk
from ...principle.trajectory import Trajectory


def knife_edge_parking(steps=100, *, goal=(0.0, 1.0, 0.0), duration=4.0, variant="+",
                       rule="midpoint"):
    """Rest-to-rest parallel parking of the knife edge, (0, 0, 0) -> `goal` = (x, y, theta).

    m = J = 1, fixed `duration`, minimizing int |u|^2 dt; returns an OptimalControlProblem.

    >>> knife_edge_parking(20).steps
    20
    """
    disc = discretize(knife_edge(mass=1.0, inertia=1.0), duration / steps, rule)
    return OptimalControlProblem(disc, steps, q_start=[0.0, 0.0, 0.0], q_goal=goal,
                                 variant=variant)


def parking_goals():
    """64 goals (x, y, theta) for `knife_edge_parking`, shape (64, 3): a 4 x 4 x 4 grid of
    x in [-0.5, 0.5], y in [0.5, 2] and theta in [-pi/4, pi/4], the batch of the batch
    tests and benchmark.

    >>> parking_goals().shape
    (64, 3)
    """
    axes = np.linspace(-0.5, 0.5, 4), np.linspace(0.5, 2.0, 4), np.linspace(-np.pi / 4, np.pi / 4, 4)
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def rolling_disk_steering(steps=100, *, duration=4.0, variant="+", rule="midpoint"):
    """Rest-to-rest steering of the vertical rolling disk to x = 1, y = 1, heading pi/2.

    Starts at (x, y, theta, phi) = 0 with the rolling angle theta free at the goal;
    m = R = 1, minimizing int |u|^2 dt; returns an OptimalControlProblem.

    >>> rolling_disk_steering(20).q_goal
    array([1.        , 1.        ,        nan, 1.57079633])
    """
    disc = discretize(rolling_disk(mass=1.0, radius=1.0), duration / steps, rule)
    return OptimalControlProblem(disc, steps, q_start=[0.0, 0.0, 0.0, 0.0],
                                 q_goal=[1.0, 1.0, None, np.pi / 2], variant=variant)


def car_lane_change(steps=60, *, duration=3.0, speed=40.0 / 3.0, rule="midpoint", variant="+"):
    """A lane change of the car (`dmoc.systems.car`, SI defaults) at cruising speed:
    (x, y, theta, delta) from (0, 0, 0, 0) to (speed * duration, 3.5, 0, 0) in `duration`
    seconds, entering and leaving at `speed` along x (m/s), minimizing int (F/m)^2 + tau^2 dt.

    With the defaults, 40 m and 3.5 m sideways in 3 s at 48 km/h. The cost weighs the
    drive force as the acceleration it gives (m = 1500 kg), so steering is not free next
    to it; the issue's version from rest with int |u|^2 converges to spurious roots of the
    step equations (docs/stages/optimize.md). Start it from `uniform_motion_guess`: the
    default guess bends the heading and steering by a tenth of the 40 m.

    >>> car_lane_change(20).q_goal
    array([40. ,  3.5,  0. ,  0. ])
    """
    system = car()
    disc = discretize(system, duration / steps, rule)
    return OptimalControlProblem(disc, steps, q_start=[0.0, 0.0, 0.0, 0.0],
                                 q_goal=[speed * duration, 3.5, 0.0, 0.0],
                                 v_start=[speed, 0.0, 0.0, 0.0], v_goal=[speed, 0.0, 0.0, 0.0],
                                 running_cost=lambda q, v, u: (u[0] / 1500.0) ** 2 + u[1] ** 2,
                                 variant=variant)


def uniform_motion_guess(problem):
    """A guess for `problem` (a Trajectory): the unforced motion at the constant velocity
    `v_start` from `q_start`, q_k = q_start + v_start t_k, with its momenta, zero
    multipliers and controls, and stages on the chords.

    For the car of `car_lane_change` it is the straight drive at the entry speed, which
    satisfies the step equations exactly.

    >>> uniform_motion_guess(car_lane_change(20)).q[-1].tolist()
    [40.0, 0.0, 0.0, 0.0]
    """
    disc, N = problem.disc, problem.steps
    t = disc.h * np.arange(N + 1)
    v = np.nan_to_num(problem.v_start)
    q = np.nan_to_num(problem.q_start) + np.outer(t, v)
    p = np.array(disc.system.momentum.map(N + 1)(q.T, np.tile(v, (N + 1, 1)).T)).T
    return Trajectory(t, q, p, np.zeros((N, disc.n_multipliers)), np.zeros((N, disc.n_controls)),
                      disc.h, problem.variant, s=disc.rule.stage_guess(q, p),
                      control_nodes=disc.rule.control_nodes)
