"""The judged solve of a `GroupOptimalControlProblem` (a driver): IPOPT's optimum on SO(3)
judged by its verdict (`dmoc.drivers.group_verdict`), and `judged_level_solve`, the judged
solve of a problem of either kind that `dmoc.optimize`, its accuracy target
(`dmoc.drivers.accuracy`) and its error estimate (`dmoc.drivers.error_estimate`) run, so
that a problem on the group goes through the same drivers as one on R^n."""

import time

from .._util import checks
from ..errors import InputError
from ..optimal_control.nlp.group_transcription import group_transcription
from ..optimal_control.solver.group_solving import solve_on_group
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from .group_verdict import judge_on_group
from .high_order import started_solve
from .verdict import judged

# the keywords of `dmoc.optimize` a problem on the group takes (the others keep their defaults)
GROUP_KEYWORDS = ("options", "throw", "check", "estimate", "accuracy", "max_steps")


def group_keywords(*, options, throw, check, **others):
    """The keywords of the judged solve on the group, ``{"options", "throw", "check"}``;
    `others` are the keywords of `dmoc.optimize` that a problem on the group does not take,
    each a pair (value, default), refused by name (InputError) unless at its default."""
    given = sorted(name for name, (value, default) in others.items() if not _is_default(value, default))
    if given:
        raise InputError(f"`dmoc.optimize` of a GroupOptimalControlProblem takes only "
                         f"{', '.join(GROUP_KEYWORDS)}; got {', '.join(given)}.")
    return {"options": options, "throw": throw, "check": check}


def judged_solve_on_group(problem, *, options=None, throw=True, check=True):
    """Solve `problem` (`solve_on_group`) and, with `check`, judge it (`judge_on_group`): the
    result with its `verdict`, ``stats["verdict_time"]`` and ``stats["replay_deviation"]``
    (the verdict's larger replay figure, max(replay_q, replay_p)); ``success=False``, the
    verdict's status and its message when a check fails (`dmoc.drivers.verdict.judged`;
    SolverError with `throw`)."""
    check = checks.boolean("check", check)
    transcription = group_transcription(problem)         # the solve's, again the replay's
    result = solve_on_group(problem, options=options, throw=throw, transcription=transcription)
    if not (check and result.success):
        return result
    tic = time.perf_counter()
    verdict = judge_on_group(problem, result, transcription)
    result.stats["replay_deviation"] = max(verdict.replay_q, verdict.replay_p)
    return judged(result, verdict, throw=throw, seconds=time.perf_counter() - tic)


def judged_level_solve(problem, *, guess=None, **keywords):
    """The judged solve of `problem`: `started_solve` from `guess` on R^n,
    `judged_solve_on_group` on the group (from its geodesic guess: `guess`, the optimum of
    another level, is not used there; `keywords` its own, `group_keywords`)."""
    if isinstance(problem, GroupOptimalControlProblem):
        return judged_solve_on_group(problem, **keywords)
    return started_solve(problem, guess=guess, **keywords)


def _is_default(value, default):
    """Whether a keyword's `value` is its `default` (None, a bool or a number)."""
    return value is default or (type(value) is type(default) and value == default)
