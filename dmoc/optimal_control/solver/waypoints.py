"""A guess from waypoints (consumer 2, the optimizer's start point): a Trajectory on a
problem's grid whose configurations follow a C^1 piecewise cubic through the user's
waypoints, with the momenta of its velocity (p = dL/dv(q, q')) at the knots, the stage
configurations on the same curve at the rule's stage nodes, and zero controls and
multipliers; ``optimize(problem, guess=from_waypoints(problem, q))`` starts from it.
"""

import numpy as np

from ..._util import checks
from ...discrete import Discretization
from ...errors import InputError
from ...principle.trajectory import Trajectory
from ..statement.problem import OptimalControlProblem


def from_waypoints(target, q, times=None, *, steps=None):
    """A Trajectory through the waypoints `q` on the grid of `target`, for `optimize`'s guess.

    Parameters
    ----------
    target : OptimalControlProblem or Discretization
        The grid: a problem's N steps of h (``disc.h``, within its final time's range), or a
        discretization's h and `steps`.
    q : array_like, shape (K, n)
        Waypoints, K >= 2.
    times : array_like, shape (K,), optional
        Their times, increasing from 0 to the horizon N h; default evenly spaced.
    steps : int, optional
        N, required with a Discretization (a problem has its own).

    Returns
    -------
    Trajectory
        q(t) the piecewise cubic Hermite curve through the waypoints, its slopes the
        derivatives of the parabolas through three neighbouring waypoints (at the ends:
        the problem's fully given v_start, v_goal, else the parabola's); the knots' q and
        p = dL/dv(q, q'), the stages at the rule's `stage_nodes` on the curve (the rule's
        `stage_guess` when its stages are not configurations), controls and multipliers 0;
        the problem's variant ("+" for a Discretization). Exact for waypoints on a line,
        or a parabola, in time.

    Examples
    --------
    >>> import dmoc
    >>> problem = dmoc.problems.knife_edge_parking(20)
    >>> guess = from_waypoints(problem, [[0, 0, 0], [0.3, 0.5, 0.6], [0, 1, 0]])
    >>> guess.q.shape, dmoc.optimize(problem, guess=guess).success
    ((21, 3), True)
    """
    disc, N, h, ends = _grid(target, steps)
    variant = target.variant if isinstance(target, OptimalControlProblem) else "+"
    sys, rule = disc.system, disc.rule
    q = checks.real_array("q", q, "an array of waypoints of shape (K, n)")
    if q.ndim != 2 or q.shape[0] < 2 or q.shape[1] != sys.n:
        raise InputError(f"`q` must have shape (K, {sys.n}) with K >= 2 waypoints; got {q.shape}.")
    q = checks.array("q", q, q.shape)
    times = _times(times, q.shape[0], N * h)
    slopes = _slopes(times, q, ends)
    t = h * np.arange(N + 1)
    knots, velocities = hermite(times, q, slopes, t)
    p = np.array(sys.momentum.map(N + 1)(knots.T, velocities.T)).T
    if rule.n_stage_blocks == len(rule.stage_nodes):          # stages = configurations
        at_stages = (t[:-1, None] + h * np.asarray(rule.stage_nodes)).ravel()
        s = hermite(times, q, slopes, at_stages)[0].reshape(N, -1)
    else:
        s = rule.stage_guess(knots, p)
    return Trajectory(t, knots, p, np.zeros((N, disc.n_multipliers)), np.zeros((N, disc.n_controls)),
                      h, variant, s=s, control_nodes=rule.control_nodes, stage_nodes=rule.stage_nodes)


def hermite(times, q, slopes, t):
    """(q(t), q'(t)), shapes (len(t), n): the cubic Hermite curve with values `q` and
    `slopes` (K, n) at `times` (K,), at times `t` in [times[0], times[-1]]."""
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    H = (times[i + 1] - times[i])[:, None]
    s = (t - times[i])[:, None] / H
    value = ((2 * s**3 - 3 * s**2 + 1) * q[i] + (s**3 - 2 * s**2 + s) * H * slopes[i]
             + (3 * s**2 - 2 * s**3) * q[i + 1] + (s**3 - s**2) * H * slopes[i + 1])
    slope = ((6 * s**2 - 6 * s) * (q[i] - q[i + 1]) / H + (3 * s**2 - 4 * s + 1) * slopes[i]
             + (3 * s**2 - 2 * s) * slopes[i + 1])
    return value, slope


def _slopes(times, q, ends):
    """Slopes (K, n): inside, the derivative of the parabola through the waypoint and its
    neighbours, the secants weighted by the opposite spacings; at an end the given
    velocity of `ends` (NaN where not given), else the parabola's (the secant for K = 2)."""
    H = np.diff(times)[:, None]
    d = np.diff(q, axis=0) / H
    slopes = np.empty_like(q)
    slopes[1:-1] = (d[:-1] * H[1:] + d[1:] * H[:-1]) / (H[:-1] + H[1:])
    if len(times) == 2:
        slopes[0] = slopes[-1] = d[0]
    else:
        slopes[0] = ((2 * H[0] + H[1]) * d[0] - H[0] * d[1]) / (H[0] + H[1])
        slopes[-1] = ((2 * H[-1] + H[-2]) * d[-1] - H[-1] * d[-2]) / (H[-1] + H[-2])
    for row, given in ((0, ends[0]), (-1, ends[1])):
        slopes[row] = np.where(np.isfinite(given), given, slopes[row])
    return slopes


def _grid(target, steps):
    """(disc, N, h, (v_start, v_goal)) of a problem or of a discretization and `steps`."""
    checks.instance("target", target, (OptimalControlProblem, Discretization),
                    "an OptimalControlProblem or a Discretization")
    if isinstance(target, Discretization):
        if steps is None:
            raise InputError("`steps` is required with a Discretization: the guess's grid is "
                             "`steps` steps of disc.h.")
        nan = np.full(target.system.n, np.nan)
        return target, checks.positive_int("steps", steps), target.h, (nan, nan)
    if steps is not None:
        raise InputError(f"`steps` must be None with a problem, which has {target.steps}.")
    N = target.steps
    h = float(np.clip(target.disc.h, *target.final_time.step_range(N)))
    v_start = target.v_start if np.isfinite(target.q_start).all() else np.full(target.disc.system.n, np.nan)
    v_goal = target.v_goal if np.isfinite(target.q_goal).all() else np.full(target.disc.system.n, np.nan)
    return target.disc, N, h, (v_start, v_goal)


def _times(times, K, T):
    """Waypoint times, shape (K,): increasing from 0 to T (to round-off), default even."""
    if times is None:
        return np.linspace(0.0, T, K)
    times = checks.vector("times", times, K)
    if np.any(np.diff(times) <= 0) or abs(times[0]) > 1e-9 * T or abs(times[-1] - T) > 1e-9 * T:
        raise InputError(f"`times` must increase from 0 to the horizon N h = {T!r}; got "
                         f"{times.tolist()}.")
    return np.concatenate([[0.0], times[1:-1], [T]])
