"""Ready-made DMOC problems on the built-in systems, shared by the examples, the
command-line demo and the benchmarks so that they all solve the same thing."""

import numpy as np

from ..discrete import discretize
from .problem import OptimalControlProblem
from ..mechanics.systems import knife_edge, rolling_disk


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
