"""The default start of a high-order rule (a driver, issue 40): a stage rule (lobatto3,
lobatto4) from the default guess is first solved with the midpoint rule on the same grid,
and its solve starts from that optimum, resampled (`dmoc.optimal_control.solver.guess`),
instead of from the default guess (docs/stages/drivers.md, "High-order rules from the
default guess"). A problem without inequalities (every row an equality, no bound but the
boundary data, a fixed final time) is solved from the default guess first, and by way of
the midpoint optimum only when that optimum fails (its verdict or IPOPT).

From the default guess the stage rule's NLP can converge to an optimum whose steps sit on
another root of the step equations (37)/(41) at large h, with stage values far from the
rule's interpolant of the motion; the replay then fails (verdict ``"not_replayable"``).
The midpoint rule has no stage values and one root near the chord; its optimum puts the
stage rule's start on the physical branch, where Newton's method of the replay finds the
same root. With inequalities the start also chooses the active set (the bounded disk's
lobatto3 at N = 60 from the default guess passes its verdict on a worse optimum); without
them the verdict catches the other root, so the midpoint solve is spent only then."""

import time

from .._util import checks, deferred
from ..errors import Status, failure
from ..optimal_control import OptimalControlProblem
from ..optimal_control.solver.newton_kkt import applies
from ..optimal_control.solver.solving import solve
from .verdict import judged_solve

# The rule whose optimum starts a stage rule's solve from the default guess.
ROBUST_RULE = "midpoint"
# IPOPT's barrier start of the stage rule's solve from that optimum, under the user's
# `options`: the start is within the rules' difference of the optimum, and IPOPT's
# default mu_init 0.1 first pushes it off its active bounds and rows. The truck backing a
# trailer into a bay (tests/optimize/hard_problems.py), lobatto3 at N = 60: 319 iterations
# with 0.1, 506 with 1e-2, 30 with 1e-3, 14 with 1e-4, 10 with 1e-5, the same optimum.
STARTED_OPTIONS = {"mu_init": 1e-5}


def starts_robustly(problem, guess):
    """True when `optimize` solves `problem` from `guess` by way of the ROBUST_RULE's
    optimum: no guess and a rule of order above 2."""
    return guess is None and problem.disc.rule.order > 2


def equality_constrained(problem):
    """True when `problem`'s NLP has no inequality: every row an equality and no entry of
    x bounded but the fixed ones (the boundary data), so no free final time
    (`dmoc.optimal_control.solver.newton_kkt.applies`)."""
    T = problem.transcription
    return applies(T, T.lbx / T.x_scale, T.ubx / T.x_scale, *T.scaled_g_bounds)


def robust_start(problem, *, options=None, reuse_solver=True, expand=False, jit=False):
    """(the ROBUST_RULE's optimum of `problem` on its grid, or None when that solve failed;
    the record of the start for ``stats["start"]``: rule, status, iterations, time)."""
    tic = time.perf_counter()
    start = solve(problem.with_rule(ROBUST_RULE), options=options, reuse_solver=reuse_solver,
                  expand=expand, jit=jit, throw=False)
    record = {"rule": ROBUST_RULE, "status": str(start.status), "iterations": start.stats["iterations"],
              "time": time.perf_counter() - tic}
    return (start if start.success or start.status == Status.INTERRUPTED else None), record


def started_solve(problem, *, guess=None, throw=True, options=None, **keywords):
    """`judged_solve` of `problem` from `guess`, from the ROBUST_RULE's optimum instead of
    the default guess when `starts_robustly` (with STARTED_OPTIONS under the user's
    `options`): that start's record in ``stats["start"]`` (None otherwise), its iterations
    not counted in ``stats["iterations"]``; a failed start falls back to the default guess
    and `options`. An `equality_constrained` problem is solved from the default guess
    first, and so only when that fails (the failure's status in the record, "after").
    `dmoc.optimize` documents the keywords."""
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    if not starts_robustly(problem, guess):
        return judged_solve(problem, guess=guess, throw=throw, options=options, **keywords)
    after = None
    if equality_constrained(problem):
        plain = judged_solve(problem, throw=False, options=options, **keywords)
        if plain.success or plain.status == Status.INTERRUPTED:
            return _thrown(plain, throw)
        after = str(plain.status)
    same = {k: keywords[k] for k in ("reuse_solver", "expand", "jit") if k in keywords}
    start, record = robust_start(problem, options=options, **same)
    if after is not None:
        record["after"] = after
    if start is not None and start.status == Status.INTERRUPTED:
        result = start
    elif start is not None:
        result = judged_solve(problem, guess=start.trajectory, throw=False,
                              options={**STARTED_OPTIONS, **(options or {})}, **keywords)
    else:
        result = judged_solve(problem, throw=False, options=options, **keywords)
    return _thrown(deferred.replace(result, stats={**result.stats, "start": record}), throw)


def _thrown(result, throw):
    """`result`, raised as its failure with `throw` when it did not succeed."""
    if throw and not result.success:
        raise failure(result.message + " The result is in `.result`.", result)
    return result


__all__ = ["started_solve", "robust_start", "starts_robustly", "equality_constrained", "ROBUST_RULE",
           "STARTED_OPTIONS"]
