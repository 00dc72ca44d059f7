"""The path constraints on the rule's interpolant between the knots (a driver, issue 40):
the rows g(q, v, u, w) read at step times inside the steps, on the polynomial the rule
evaluates L on (`Trajectory.sample`), where the NLP does not impose them. The verdict
(`dmoc.drivers.verdict`) reads them at evenly spread points of every step and refuses an
optimum whose interpolant cuts into a limit by a large part of the row's scale; the active
set test of the error estimate (`dmoc.drivers.active_limits.touches`) reads them at the
rule's interior points, where the NLP does impose them.
"""

import numpy as np

from .._util.numeric import mapped
from ..principle import dense

# The step times c = (j + 1/2) / 8, j = 0 ... 7, where the verdict reads the path rows
# between the knots: every gap between the points where the NLP imposes them (the knots
# and the rule's interior points, 0, 1/2, 1 for midpoint and lobatto3, 0, 0.28, 0.72, 1
# for lobatto4) holds two or more of them. On the keep-out discs of the verdict study
# (benchmarks/verdict.py --study) the largest of these values is 0.87 to 1 times the
# largest at 40 points per step (a cut spanning a gap h/2: at least 15/16 of its peak).
BETWEEN_KNOTS = tuple((j + 0.5) / 8 for j in range(8))
# An interpolant that exceeds a path row between the knots by more than this part of the
# row's scale max(1, max |g|) does not resolve the limit: the NLP holds the row at its
# points only, so a resolved motion cuts into it by O(h^2) between them, a small part of
# the row's range (the right optima of the verdict study: 5e-4 to 7.2e-2, the largest a
# rolling disk on 3 lobatto3 steps whose cost is 17 % off and estimated 9 % off); a
# Chaplygin sleigh past a disc on 3 lobatto3 steps cuts it by 0.25 (its cost 71 % off,
# DOP853 under its controls 0.32 of the span away; velocity jump 0.44, replay 1e-15).
CUT_LIMIT = 0.1


def interpolant_path_values(problem, traj, nodes=BETWEEN_KNOTS):
    """The path constraints of `problem` on the interpolant of `traj` at the step times
    `nodes` of every step.

    Parameters
    ----------
    problem : OptimalControlProblem
        With ``path_constraints`` (a Function (q, v, u, w) -> g, rows of g <= 0).
    traj : Trajectory
        An optimum of `problem` on N steps.
    nodes : sequence of float
        Step times c in [0, 1].

    Returns
    -------
    times : ndarray, shape (N len(nodes),)
        t_k + c h, step after step.
    g : ndarray, shape (N len(nodes), rows)
        g at (q(t), q'(t), u(t)) of the rule's interpolant (`Trajectory.sample`), with the
        parameters at c as the NLP reads them (`ParameterSchedule.point_function`, the
        step's values at every c where they do not vary within a step).
    """
    nodes = np.asarray(nodes, dtype=float)
    times = (traj.t[:-1, None] + traj.h * nodes[None, :]).ravel()
    k, c = np.repeat(np.arange(traj.steps), nodes.size), np.tile(nodes, traj.steps)
    q, v = dense.configurations(traj, k, c)         # `Trajectory.sample` without p
    u = dense.controls(traj, k, c)
    w = np.repeat(problem.parameters.knot_values()[:, :-1], nodes.size, axis=1)
    at = problem.parameters.schedule.point_function()
    if at is not None:
        (w,) = mapped(at, times.size)(w, c, np.full(times.size, traj.h))
    (g,) = mapped(problem.path_constraints, times.size)(q.T, v.T, u.T, w)
    return times, g.T


def cut_message(verdict, traj):
    """What a verdict whose interpolant cuts into a path row between the knots found, and
    what to do (`dmoc.drivers.verdict.verdict_message`)."""
    k = verdict.path_cut_step
    return (f"{verdict.path_cut_limit} is exceeded between knots {k} and {k + 1} (t = "
            f"{traj.t[k]:.4g} to {traj.t[k + 1]:.4g}) on the rule's interpolant by "
            f"{verdict.path_cut:.2e} of the row's scale max(1, max |g|) (limit {CUT_LIMIT:g}), "
            f"although it holds at the knots and the rule's interior points, where the NLP "
            f"imposes it: the grid does not resolve the limit. Use more steps (the cut shrinks "
            f"as h^2), or keep a margin in the limit")


__all__ = ["interpolant_path_values", "cut_message"]
