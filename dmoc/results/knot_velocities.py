"""How well the grid resolves an optimum's motion (results stage): the velocities of each
step's interpolant at its two ends (the rule's polynomial through q_k, the stage
configurations and q_{k+1}), their jumps at the knots relative to each coordinate's peak,
and the jumps of the step velocities; the verdict on an optimum reads them
(`dmoc.drivers.verdict`), for one trajectory or many in one call.
"""

import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from .._util.numeric import Evaluator
from ..discrete.knot_states import end_velocity_function
from ..principle.trajectory import Trajectory, check_trajectory
from . import figure_rules
from .figure_rules import NUMPY

# the end velocities' Function mapped over a number of steps, evaluated through its buffer:
# keyed by (rule, n, stage rows, steps), so a verdict per re-solve builds nothing
_MAPPED = BoundedCache(32, "end_velocity_maps")


def end_velocities(disc, traj):
    """The velocities of each step's interpolant at its two ends, shapes (N, n) and (N, n):
    q'_k(0) and q'_k(h) of the rule's polynomial through q_k, the stage configurations and
    q_{k+1} (`Rule.interpolant`); both (q_{k+1} - q_k)/h for the midpoint and trapezoid
    rules. The step's Function (`dmoc.discrete.knot_states.end_velocity_function`) is built
    once per rule, n and stage rows and kept: a verdict per re-solve does not rebuild it.
    The one-trajectory case of `end_velocities_of`; InputError unless `traj` fits `disc`
    (`check_trajectory`: a Discretization and a Trajectory, not their forms on SO(3))."""
    check_trajectory(disc, traj)
    return end_velocities_of([(disc, traj)])[0]


def end_velocities_of(pairs):
    """`end_velocities` of each (disc, traj) of `pairs`, a list of (start, end) pairs: the
    trajectories of one rule, n and stage rows in one call of the kept step Function
    mapped over all their steps, their columns one trajectory after another. A serial map
    evaluates the step's Function column by column, so each trajectory's velocities are
    those of a call of its own bit for bit. The mapped Function is kept per number of
    steps and called through its buffer (`dmoc._util.numeric.Evaluator`: the same
    evaluation without conversions to ``casadi.DM``, which cost 7-12 times the call)."""
    found = {}
    for i, (disc, traj) in enumerate(pairs):
        found.setdefault((disc.rule, disc.system.n, traj.s.shape[1]), []).append(i)
    ends = [None] * len(pairs)
    for key, members in found.items():
        trajs = [pairs[i][1] for i in members]
        steps = [traj.steps for traj in trajs]
        mapped = _MAPPED.get((*key, sum(steps)),
                             lambda: Evaluator(end_velocity_function(*key).map(sum(steps))))
        start, end = (x.T for x in mapped(      # rows of steps: the columns of the map, flat
            np.vstack([traj.q[:-1] for traj in trajs]).ravel(),
            np.vstack([traj.q[1:] for traj in trajs]).ravel(),
            np.vstack([traj.s for traj in trajs]).ravel(), np.repeat([traj.h for traj in trajs], steps)))
        bounds = np.cumsum(steps)[:-1]
        for i, a, b in zip(members, np.split(start, bounds), np.split(end, bounds)):
            ends[i] = (a, b)
    return ends


def velocity_changes(disc, traj, *, ends=None):
    """The jump of the velocity of the rule's interpolant at every interior knot relative to
    its coordinate's peak, shape (N - 1, n): row k - 1 holds |q'_k(0) - q'_{k-1}(h)| /
    max |q'| per coordinate (`end_velocities`, or `ends`, what it returned for `traj`
    already); 0 for a coordinate at rest (peak below 1e-9 of the largest coordinate's).

    For the midpoint and trapezoid rules q'_k is the step velocity (q_{k+1} - q_k)/h and
    the largest entry per coordinate is `velocity_jumps`; a stage rule's polynomials meet
    with a velocity jump of the order of its error, so a coarse grid that a high-order rule
    resolves is not mistaken for an unresolved one.
    """
    if not check_trajectory(disc, traj) or traj.steps < 2:
        return np.zeros((0, disc.system.n))
    return relative_changes(*(end_velocities(disc, traj) if ends is None else ends))


def relative_changes(start, end):
    """|start_k - end_{k-1}| / peak per coordinate at the interior knots k = 1 ... N - 1,
    shape (N - 1, n), of the velocities `start` and `end` (N, n) of each step's
    interpolant at its two ends, the peak max |start|, |end| of each coordinate; 0 for a
    coordinate at rest (peak below 1e-9 of the largest coordinate's). The figure of
    `velocity_changes`, and of the verdict on SO(3), whose velocities are the body angular
    velocity and x' (`dmoc.drivers.group_verdict`). Stated in `figure_rules`, which the
    light verdict's compiled figures evaluate too."""
    return figure_rules.relative_changes(NUMPY, start, end)


def velocity_jumps(traj):
    """How well the grid resolves the motion, per coordinate, shape (n,):
    max_k |v_{k+1/2} - v_{k-1/2}| / max_k |v_{k+1/2}| over the step velocities
    (`Trajectory.velocities`).

    A motion resolved by the grid gives about omega h (2 sin(omega h / 2) for a sinusoid of
    frequency omega). Values of order 1 say that the velocity changes by its own size
    within a step (2: it reverses): the grid does not resolve the motion, as in the optima
    that spin a light blade by pi per step and slip it sideways in one step
    (docs/verification.md, "Known shortfalls"). Coordinates at rest (peak velocity below
    1e-9 of the largest coordinate's) give 0. `velocity_changes` measures the jumps of a
    stage rule's interpolant instead.

    >>> traj = Trajectory([0, 1, 2, 3], [[0.0], [1.0], [0.0], [1.0]], [[0.0]] * 4, [[], [], []],
    ...                   [[], [], []], 1.0, "+")
    >>> velocity_jumps(traj)
    array([2.])
    """
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    v = traj.velocities
    if v.shape[0] < 2:
        return np.zeros(v.shape[1])
    peak = np.abs(v).max(axis=0)
    moving = peak > 1e-9 * peak.max(initial=0.0)
    return np.where(moving, np.abs(np.diff(v, axis=0)).max(axis=0) / np.where(moving, peak, 1.0), 0.0)
