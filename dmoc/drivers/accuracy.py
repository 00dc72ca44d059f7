"""The accuracy target, a driver (issue 23): `optimize_to_accuracy` refines the grid,
N_{k+1} = N_k (2 e_k / accuracy)^(1/p), each level warm-started from the last, until the
Richardson estimate e_k of the discretization error of the cost and of the re-simulated
final state, and of the final time where it is free (`dmoc.drivers.error_estimate`),
is below a target (docs/stages/drivers.md,
"Accuracy targets and error estimates")."""

import math
import time

from .._util import checks
from .._util.deferred import replace
from ..errors import InputError, SolverError, Status, failure
from ..optimal_control import OptimalControlProblem
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from .active_limits import barrier_offset
from .error_estimate import richardson_estimate, with_estimate
from .group_optimum import judged_level_solve

# Targets below this are refused: the estimate is a difference of costs that IPOPT (tol
# 1e-10 on the scaled NLP) and round-off know to about 1e-10 relative.
SMALLEST_ACCURACY = 1e-9
# A level multiplies N by at most this, whatever a pre-asymptotic estimate predicts.
GROWTH = 16
# what to do where IPOPT's own offset from the bounds it holds is too large
_SMALLER_TOL = "a smaller IPOPT tolerance (`options={\"tol\": ...}`: the offset shrinks in proportion)"


def optimize_to_accuracy(problem, accuracy, *, guess=None, max_steps=100_000, **keywords):
    """Solve `problem` on finer and finer grids until the estimated relative error of its
    cost, of its re-simulated final state and of a free final time is below `accuracy`
    (`estimate_error`).

    Parameters
    ----------
    problem : OptimalControlProblem or GroupOptimalControlProblem
        The first level: its N and rule. Start coarse (N of 10 to 20 with a stage rule):
        the first two levels only measure the error. A problem on SO(3) solves every level
        from its geodesic guess, judged by `dmoc.drivers.group_verdict` (its rule, the
        midpoint/Cayley step, has order 2).
    accuracy : float
        The target of `ErrorEstimate.largest`, relative: of the cost to |J|, of each
        coordinate of the final configuration to its excursion over the optimum, of a free
        final time to T_N. In
        [SMALLEST_ACCURACY, 1).
    guess : Trajectory or OptimizationResult, optional
        The first level's guess (`dmoc.optimize`); each later level starts from the last
        level's optimum, resampled.
    max_steps : int
        The largest N a level may have; beyond it the loop stops with status
        ``"accuracy_not_reached"``.
    **keywords
        Passed to the judged solve of every level (`dmoc.optimize`'s ``options``,
        ``throw``, ``check``, ...).

    Returns
    -------
    OptimizationResult
        The last level's, with ``stats["levels"]`` (one dict per level: ``steps``,
        ``rule``, ``cost``, ``status``, ``iterations``, ``estimate`` (its
        `ErrorEstimate.largest`; None on the first level), ``time``, wall seconds of
        the level's problem, solve and estimate, and ``start``, the record of the
        midpoint start of a stage rule's first level or None, `dmoc.drivers.high_order`) and ``stats["error_estimate"]`` (the last
        `ErrorEstimate` as a dict of plain numbers and lists, so `OptimizationResult.save`
        keeps it).

    Raises
    ------
    SolverError
        A level's solve failed, or the target needs more than `max_steps` steps, with
        ``throw=True`` (the default); ``.result`` is the last level's. With ``throw=False``
        the result comes back with ``success=False``.
    Interrupted
        A Ctrl-C stopped a level's solve, with ``throw=True``; ``.result`` is that level's
        last iterate, ``stats["levels"]`` the levels so far.

    Notes
    -----
    Level 2 has 2N steps; then the error C N^-p measured at N_k predicts the N at which
    it is half the target, N_{k+1} = N_k (2 e_k / accuracy)^(1/p), at most ``GROWTH``
    N_k, and each level's estimate compares its cost with the level before. The first
    level of a stage rule from the default guess starts from the midpoint rule's optimum
    (`dmoc.drivers.high_order`). Every level
    is judged (`dmoc.drivers.verdict`); where a control bound switches inside the horizon
    (`ErrorEstimate.switching`) the cost and the final time are extrapolated with order 1,
    and N grows by up to GROWTH a level. One the verdict finds under-resolved is refined
    to 2N like the first, any other failure ends the loop. The rule stays the problem's:
    a higher order reaches small targets on far fewer steps (benchmarks/accuracy.py).
    IPOPT's own offset from the bounds it holds (`ErrorEstimate.solver`) grows with N:
    where it exceeds half the target the loop stops ("accuracy_not_reached"), and it
    stops before a level whose offset, predicted from the levels so far
    (`_predicted_offset`), would, rather than solve that level to refuse it.
    """
    checks.instance("problem", problem, (OptimalControlProblem, GroupOptimalControlProblem),
                    "an OptimalControlProblem or a GroupOptimalControlProblem")
    accuracy = _accuracy(accuracy)
    max_steps = checks.positive_int("max_steps", max_steps)
    levels, level, previous, tic = [], problem, None, time.perf_counter()
    offsets = []            # (N, IPOPT's offset from the bounds) of each level
    while True:
        result = judged_level_solve(level, guess=guess if previous is None else previous.trajectory,
                                    **{**keywords, "throw": False})
        coarse = result.status == Status.UNDER_RESOLVED      # what more steps cure: refine
        estimate = None if previous is None or not result.success else \
            richardson_estimate(level, result, previous, time.perf_counter())
        levels.append(_level_record(level, result, estimate, time.perf_counter() - tic))
        tic = time.perf_counter()
        if not (result.success or coarse) or (estimate is not None and estimate.largest <= accuracy):
            return _finished(level, result, levels, estimate, accuracy, keywords)
        if estimate is not None and estimate.solver > accuracy / 2:     # more steps make it larger
            return _finished(level, result, levels, estimate, accuracy, keywords, level.steps)
        steps = 2 * level.steps if estimate is None else _next_steps(level.steps, estimate, accuracy)
        if steps > max_steps:
            return _finished(level, result, levels, estimate, accuracy, keywords, max_steps)
        offsets.append((level.steps, _offset(level, result, estimate)))
        predicted = _predicted_offset(offsets, steps)
        if predicted > accuracy / 2:            # the next level would end so: stop before it
            return _finished(level, result, levels, estimate, accuracy, keywords, level.steps,
                             (steps, predicted))
        level, previous = level.with_steps(steps), result


def _offset(problem, result, estimate):
    """IPOPT's offset from the bounds it holds (`ErrorEstimate.solver`) of the level
    `problem`'s `result`, computed where the level has no `estimate` (the first); 0 on
    SO(3), whose NLP bounds only the boundary data."""
    if estimate is not None:
        return estimate.solver
    return 0.0 if isinstance(problem, GroupOptimalControlProblem) else barrier_offset(problem, result)


def _predicted_offset(offsets, steps):
    """IPOPT's offset from the bounds it holds (`ErrorEstimate.solver`) predicted on
    `steps` steps from the levels' (N, offset) pairs `offsets`, the last the latest:
    s (steps / N)^g from the last level's s on N steps, g the growth measured between the
    last two levels (log(s / s') / log(N / N')), at least 1.

    The interior point stays mu / |lam_i| off each bound it holds, and the cost of that
    shift, sum |lam_i| mu / |lam_i| over the bounds held, grows at least in proportion to
    their number, so to N; where IPOPT's last barrier parameter or the multipliers change
    with N it grows faster (the knife edge's minimum time with -0.5 <= u0 <= 1, lobatto4:
    doubling from 13 to 104 steps, times 4 per doubling from 104 to 416), which the
    measured growth follows."""
    N, offset = offsets[-1]
    growth = 1.0
    if len(offsets) > 1 and offsets[-2][1] > 0 and offset > 0:
        growth = max(1.0, math.log(offset / offsets[-2][1]) / math.log(N / offsets[-2][0]))
    return offset * (steps / N) ** growth


def _accuracy(value):
    """`value` as a float in [SMALLEST_ACCURACY, 1), else InputError."""
    value = checks.positive_float("accuracy", value)
    if not SMALLEST_ACCURACY <= value < 1.0:
        raise InputError(f"`accuracy` must be a relative error in [{SMALLEST_ACCURACY:g}, 1); got "
                         f"{value!r}. Below {SMALLEST_ACCURACY:g} IPOPT's tolerance and round-off "
                         f"make up the differences the estimate is built from.")
    return value


def _next_steps(steps, estimate, accuracy):
    """The N at which the error C N^-p estimated at `steps` is half of `accuracy`: more
    than `steps`, at most GROWTH times it."""
    growth = (2.0 * estimate.largest / accuracy) ** (1.0 / estimate.order)
    if not math.isfinite(growth):       # the optimum did not replay: refine the most
        return steps * GROWTH
    return max(steps + 1, math.ceil(steps * min(growth, GROWTH)))


def _level_record(problem, result, estimate, seconds):
    return {"steps": problem.steps, "rule": _rule_name(problem), "cost": result.cost,
            "status": result.status, "iterations": result.stats["iterations"],
            "estimate": None if estimate is None else estimate.largest, "time": seconds,
            "start": result.stats.get("start")}


def _rule_name(problem):
    """The name of the rule of `problem` (on the group the rule is its name, "midpoint")."""
    rule = problem.disc.rule
    return rule if isinstance(rule, str) else rule.name


def _finished(problem, result, levels, estimate, accuracy, keywords, max_steps=None, predicted=None):
    """The last level's (of `problem`) result with the levels and the estimate in its stats; status
    ``"accuracy_not_reached"`` when `max_steps` stopped the loop (or IPOPT's own offset,
    `ErrorEstimate.solver`, exceeds half the target, or is `predicted` to on the next
    level, (steps, offset): `max_steps` the level's steps then); SolverError with throw
    when it failed."""
    result = replace(result, stats={**result.stats, "levels": levels})
    if estimate is not None:
        result = with_estimate(result, estimate)
    stats = result.stats
    if max_steps is None and not result.success:        # a level failed its solve or verdict
        if keywords.get("throw", True):
            raise failure(result.message + " The last level's result is in `.result`.",
                          result)
        return result
    if max_steps is None:
        message = (
            f"{result.message} Accuracy {accuracy:g} reached on {levels[-1]['steps']} steps "
            f"({levels[-1]['rule']}) after {len(levels)} levels: estimated relative error "
            f"{estimate.cost:.1e} of the cost, {estimate.final_state:.1e} of the final state"
            + (f", {estimate.final_time:.1e} of the final time." if problem.free_time else ".")
            + (" A control bound switches inside the horizon: the estimates of the cost and "
               "the final time assume order 1, a conservative guess, not a bound."
               if estimate.switching else ""))
        return replace(result, stats=stats, message=message)
    figure = "not yet estimated" if estimate is None else f"{estimate.largest:.1e}"
    message = (f"Accuracy {accuracy:g} not reached: the estimated relative error is "
               f"{figure} on {levels[-1]['steps']} steps and the next level "
               f"would need more than `max_steps` = {max_steps}; raise `max_steps`"
               + ("." if isinstance(problem, GroupOptimalControlProblem) else
                  " or use a rule of higher order (lobatto3, lobatto4)."))
    if estimate is not None and estimate.solver > accuracy / 2:
        message = (f"Accuracy {accuracy:g} not reached: on {levels[-1]['steps']} steps IPOPT's "
                   f"interior point stays off the bounds it holds by {estimate.solver:.1e} of "
                   f"the cost (`ErrorEstimate.solver`), more than half the target, and more "
                   f"steps make that larger; pass {_SMALLER_TOL}.")
    elif predicted is not None:
        message = (f"Accuracy {accuracy:g} not reached: the next level would have {predicted[0]} "
                   f"steps, where IPOPT's interior point would stay off the bounds it holds by "
                   f"about {predicted[1]:.1e} of the cost (`ErrorEstimate.solver`, "
                   f"{_offset(problem, result, estimate):.1e} on {levels[-1]['steps']} steps, "
                   f"growing with N), more than half the target, so it was not solved. "
                   f"Pass {_SMALLER_TOL}.")
    result = replace(result, success=False, status=Status.ACCURACY_NOT_REACHED, message=message,
                     stats=stats)
    if keywords.get("throw", True):
        raise SolverError(message + " The last level's optimum is in `.result`.", result)
    return result


__all__ = ["optimize_to_accuracy", "SMALLEST_ACCURACY", "GROWTH"]
