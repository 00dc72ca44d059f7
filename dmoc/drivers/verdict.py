"""A verdict on every optimum (a driver): `judged_solve` is IPOPT's solve
(`dmoc.optimal_control.solve`) followed by `judge` (what the public `dmoc.optimize` runs),
which checks what IPOPT returned against the step equations (37)/(41) as `simulate` solves
them, the grid's resolution of the motion and the path constraints at every knot q_k, and
turns a converged NLP that fails them into ``success=False`` with a status naming the cause.
It is a driver because the replay needs both consumers of the step residual, which never
import each other.
"""

import time

import numpy as np

from .._util import checks, deferred
from ..errors import SolverError, Status
from ..optimal_control.solver.solving import solve
from ..optimal_control.solver.verdict_record import Verdict
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from ..optimal_control.statement.parameters import row_texts
from ..principle.rotation_trajectory import RotationTrajectory
from ..results import figure_rules
from ..results.figure_rules import NUMPY
from ..results.diagnostics import compared_momenta, replays
from ..results.knot_velocities import end_velocities, end_velocities_of, velocity_changes
from .group_verdict import judge_on_group
from .interpolant_path import BETWEEN_KNOTS, CUT_LIMIT, cut_message, interpolant_path_values
from .judged_inputs import check_judged
from .knot_checks import (knot_path_values, knot_path_values_of,  # noqa: F401 (re-exported)
                          knot_velocity_bound_values, velocity_bound_names)
from .step_replay import applies, replay_stepper, step_departure
from .verdict_figures import INDICES, figures
from .verdict_checks import (GOAL_TOLERANCE, JUMP_LIMIT, PATH_TOLERANCE,  # noqa: F401 (re-exported)
                             REPLAY_TOLERANCE, REST_TOLERANCE, largest_change, path_violation,
                             q_scale, replay_departure, worst_status)


def judge(problem, result):
    """The Verdict on an optimum of `problem`: replay, velocity jumps, path at the knots.

    Parameters
    ----------
    problem : OptimalControlProblem or GroupOptimalControlProblem
    result : OptimizationResult
        An optimum of `problem` (finite q and p). A problem on SO(3) is judged by
        `dmoc.drivers.group_verdict.judge_on_group`.

    Returns
    -------
    Verdict
        Its status is the worst failed check (`dmoc.optimal_control.solver.verdict_record.STATUSES`), or
        ``"passed"``.

    Notes
    -----
    The replay solves the step equations (37) (variant "+") or (41) (variant "-") step by
    step with Newton's method from (q_0, p_0) and the optimal controls (`dmoc.simulate`),
    which follows the root that continues the previous step (where it finds none, the
    root followed in h from a small step: `dmoc.simulation.continuation`, the branch
    that tends to the continuous flow as h -> 0); the optimum satisfies the
    same equations as NLP rows, at whatever root IPOPT reached. Their agreement to
    `REPLAY_TOLERANCE` says that IPOPT's root is the simulator's. The velocity jumps are
    those of the rule's interpolant at the knots (`dmoc.diagnostics.velocity_changes`), the
    path constraints and the velocity bounds are evaluated at every knot
    (`knot_path_values`, `knot_velocity_bound_values`). The one-optimum case of `verdicts`.
    """
    if isinstance(problem, GroupOptimalControlProblem):
        return judge_on_group(problem, result)
    check_judged(problem, result.trajectory, "result.trajectory")
    return verdicts([(problem, result)])[0]


def verdicts(pairs):
    """`judge` of each (problem, result) of `pairs`, a list of Verdicts, the same bit for
    bit as one by one, what the optima share done once: their replays in lockstep
    (`dmoc.diagnostics.replays`), the interpolants' end velocities of all of them in one
    call per rule (`end_velocities_of`), their path constraints at the knots in one call
    per path Function (`knot_path_values_of`). An error of any optimum (one `simulate`
    refuses to replay) is raised for all: judge them one by one to tell whose it is."""
    trajs = [result.trajectory for _, result in pairs]
    replayed = replays([(problem, traj) for (problem, _), traj in zip(pairs, trajs)])
    ends = end_velocities_of([(problem.disc, traj) for (problem, _), traj in zip(pairs, trajs)])
    constrained = [i for i, (problem, _) in enumerate(pairs) if problem.path_constraints is not None]
    knot_values = dict(zip(constrained, knot_path_values_of(
        [(pairs[i][0], trajs[i], ends[i]) for i in constrained])))
    return [_verdict(problem, traj, replay_departure(traj, simulated, compared_momenta(problem, traj)),
                     ends[i], knot_values.get(i))
            for i, ((problem, _), traj, simulated) in enumerate(zip(pairs, trajs, replayed))]


def _verdict(problem, traj, departure, ends, knot_values):
    """The Verdict on the optimum `traj` of `problem` from its replay's `departure` (q, p,
    first step beyond REPLAY_TOLERANCE: `replay_departure`'s or `light_judge`'s), its
    interpolant's end velocities `ends` and its path values at the knots (None without
    path constraints), which are read between the knots too (`interpolant_path_values`)."""
    T = problem.transcription
    changes = figure_rules.still(NUMPY, velocity_changes(problem.disc, traj, ends=ends), traj.q,
                                 REST_TOLERANCE * T.x_layout.unpack(T.x_scale, "q")[:, 0])
    jump, jump_step, i = largest_change(changes, range(traj.q.shape[1]))
    bounds, _ = knot_velocity_bound_values(problem, traj, ends)
    rows = 0 if knot_values is None else knot_values.shape[1]
    path, path_step, row, _ = path_violation(
        np.hstack([np.zeros((traj.steps + 1, 0)) if knot_values is None else knot_values, bounds]),
        str)
    # the rows between the knots: named only where they fail (`row_texts` builds text)
    cut, at, cut_row, _ = (0.0, -1, -1, "") if knot_values is None else path_violation(
        np.vstack([knot_values, interpolant_path_values(problem, traj)[1]]), str, traj.steps + 1)
    return _record(problem, traj, departure, (jump, jump_step, i), (path, path_step, row),
                   (cut, at, cut_row), rows)


def _record(problem, traj, departure, jump, path, cut, rows):
    """The Verdict of the figures `_verdict` or `light_judge` measured: the replay's
    `departure` (q, p, step), the largest velocity change `jump` (value, knot,
    coordinate index), the largest knot row `path` and the largest row between the knots
    `cut` (value, knot or point, row: `path_violation`'s without the name), `rows` path
    constraint rows (the velocity bounds' rows after them)."""
    replay_q, replay_p, replay_step = departure
    path, path_step, row = path
    cut, at, cut_row = cut

    def name_of(row):
        if row >= rows:
            return velocity_bound_names(problem)[row - rows]
        text = row_texts(problem.path_constraints, problem.disc.system, problem.parameters.layout)[row]
        return f"path_constraints row {row} ({text} <= 0)"
    status = worst_status({Status.NOT_REPLAYABLE: max(replay_q, replay_p) > REPLAY_TOLERANCE,
                           Status.PATH_VIOLATED: path > PATH_TOLERANCE or cut > CUT_LIMIT,
                           Status.UNDER_RESOLVED: jump[0] > JUMP_LIMIT})
    return Verdict(status, replay_q, replay_p, replay_step, jump[0], jump[1],
                   problem.disc.system.names[jump[2]], path, path_step, row if row < rows else -1,
                   path_limit=name_of(row) if row >= 0 else "", path_cut=cut,
                   path_cut_step=at // len(BETWEEN_KNOTS) if cut > 0 else -1,
                   path_cut_limit=name_of(cut_row) if cut > CUT_LIMIT else "")


def judged_solve(problem, *, check=True, throw=True, **keywords):
    """IPOPT's solve (`dmoc.optimal_control.solve`, `keywords` its own) followed by `judge`
    (by `light_judge` when the solve was a warm start from an optimum whose verdict
    passed, on the compiled NLP: ``stats["light_verdict"]``): the result with its
    `verdict` and the verdict's wall seconds in ``stats["verdict_time"]`` (the result's
    trajectory, which the verdict reads, built before: it is the solve's), whether its
    figures were the compiled evaluation's in ``stats["verdict_compiled"]``,
    ``success=False`` and the verdict's status when a check fails (SolverError with
    `throw`). `dmoc.optimize` documents the keywords."""
    check = checks.boolean("check", check)
    result = solve(problem, throw=throw, **keywords)
    if not (check and result.success):
        return result
    result.trajectory           # the solve's product, built on first reading: not the verdict's cost
    tic = time.perf_counter()
    guess = keywords.get("guess")
    light, compiled = (_light(problem, result) if result.stats["compiled"] and result.stats["warm_start"]
                       and guess.verdict is not None and guess.verdict.passed else (None, False))
    result.stats["light_verdict"], result.stats["verdict_compiled"] = light is not None, compiled
    return judged(result, light or judge(problem, result), throw=throw, seconds=time.perf_counter() - tic)


def light_judge(problem, result):
    """The Verdict on an optimum of `problem` as `judge` makes it, but for the replay: the
    simulator's compiled step from every knot of the optimum at once, not one run from its
    start; replay_step the first knot whose step departs beyond REPLAY_TOLERANCE. Its
    figures in one compiled evaluation (`dmoc.drivers.verdict_figures`), or, while that is
    not loaded or where a figure is not finite, by `step_replay.step_departure` and the
    NumPy checks. None where the step replay does not apply, is not compiled yet, or does
    not accept a step (`step_replay.applies`, `step_departure`): `judge` judges such an
    optimum (docs/verification.md, "The light verdict of a re-solve")."""
    return _light(problem, result)[0]


def _light(problem, result):
    """(`light_judge`'s Verdict or None, whether the compiled evaluation made it)."""
    traj = result.trajectory
    check_judged(problem, traj, "result.trajectory")
    if not applies(problem, traj):
        return None, False
    found = figures(problem, traj, replay_stepper(problem, traj))
    if found is not None and not found["accepted"]:
        return None, False
    if found is not None and found["finite"]:
        rows = 0 if problem.path_constraints is None else problem.path_constraints.size1_out(0)
        figure = {name: int(value) if name.endswith(INDICES) else value for name, value in found.items()}
        return _record(problem, traj, (figure["replay_q"], figure["replay_p"], figure["replay_step"]),
                       (figure["jump"], figure["jump_step"], figure["jump_coordinate"]),
                       (figure["path"], figure["path_step"], figure["path_row"]),
                       (figure["cut"], figure["cut_point"], figure["cut_row"]), rows), True
    departure = step_departure(problem, traj)
    if departure is None:
        return None, False
    replay_q, replay_p, each = departure
    beyond = np.flatnonzero(each > REPLAY_TOLERANCE)
    ends = end_velocities(problem.disc, traj)
    knots = None if problem.path_constraints is None else knot_path_values_of([(problem, traj, ends)])[0]
    return _verdict(problem, traj, (replay_q, replay_p, int(beyond[0]) + 1 if beyond.size else -1),
                    ends, knots), False


def judged(result, verdict, *, throw=True, seconds=None):
    """The converged `result` with its `verdict` (and `seconds`, what judging it cost, in
    ``stats["verdict_time"]`` unless None): as it is when the verdict passed, else
    with ``success=False``, the verdict's status and its message (`verdict_message`),
    raised as a SolverError with `throw`."""
    changes = {"verdict": verdict}      # the fields not made yet stay so (`deferred.replace`)
    if seconds is not None:
        changes["stats"] = {**result.stats, "verdict_time": seconds}
    if verdict.passed:
        return deferred.replace(result, **changes)
    result = deferred.replace(result, success=False, status=verdict.status,
                              message=verdict_message(verdict, result), **changes)
    if throw:
        raise SolverError(result.message + " The optimum is in `.result`.", result)
    return result


# an acceptable-level stop met IPOPT's looser acceptable_* tolerances only (its dual
# infeasibility up to 1e10): the point may be no optimum, and a failed check there is as
# likely that as the check's own cause (the falling cat of tests/mechanics/test_floating_base.py,
# its goal stated twice, ended so at 6x the optimal cost with a velocity jump of 1.32)
ACCEPTABLE_STOP = ("IPOPT stopped at its acceptable level, not at `tol`, so the point may be no "
                   "optimum: rows the others imply (a goal the dynamics already fix) leave the "
                   "multipliers non-unique and end solves so; state each condition once; ")


def verdict_message(verdict, result):
    """What a failed verdict found (figures, step, coordinate) and what to do."""
    traj = result.trajectory
    jump = (f"the velocity of {verdict.jump_coordinate} changes by {verdict.velocity_jump:.2f} "
            f"of its peak at knot {verdict.jump_step} (t = {traj.t[verdict.jump_step]:.4g})")
    found = {
        Status.NOT_REPLAYABLE:
            f"it does not solve the step equations as `simulate` does: {_departure(verdict, traj, jump)} "
            + _replay_remedy(traj),
        Status.GOAL_MISSED:
            f"its last knot misses the goal by {verdict.goal_error:.2e} (the angle of "
            f"R_goal^T R_N in radians, or x_N - x_goal over the span of x; limit "
            f"{GOAL_TOLERANCE:g}): IPOPT stopped at an acceptable level or on loosened "
            f"tolerances, or the optimum is another goal's. Tighten IPOPT's `tol` and "
            f"`constr_viol_tol`",
        Status.PATH_VIOLATED: cut_message(verdict, traj) if verdict.path_violation <= PATH_TOLERANCE else
            f"{verdict.path_limit} is violated at knot {verdict.path_step} "
            f"(t = {traj.t[max(verdict.path_step, 0)]:.4g}) by {verdict.path_violation:.2e} "
            f"of the row's scale max(1, max |g|) (limit {PATH_TOLERANCE:g}), although the NLP "
            f"imposes it at every knot with the same arguments: IPOPT's tolerance or a "
            f"solve on another root. Tighten IPOPT's `tol` or keep a margin in the limit",
        Status.UNDER_RESOLVED:
            f"the grid does not resolve the motion: {jump} (limit {JUMP_LIMIT:g}). Use more "
            f"steps, or bound the per-step change of that coordinate"}[verdict.status]
    status = result.stats["return_status"]
    return (f"IPOPT converged ({status}, cost {result.cost:.10g}), "
            f"but the optimum fails its verdict ({verdict.status}): {found}; "
            f"{ACCEPTABLE_STOP if status == 'Solved_To_Acceptable_Level' else ''}"
            f"docs/stages/drivers.md, \"Verdicts\".")


def _departure(verdict, traj, jump):
    """How the replay of a not_replayable `verdict` on `traj` left the optimum (its
    departures, or the step where `simulate` found no root: infinite departures), the
    velocity `jump`, and the likely cause."""
    if not np.isfinite(verdict.replay_q):
        k = verdict.replay_step
        return (f"the replay from its initial state with its controls stops on the step from "
                f"knot {k - 1} to knot {k} (t = {traj.t[k - 1]:.4g} to {traj.t[k]:.4g}), where "
                f"`simulate`'s Newton iteration finds no root of the step equations, neither "
                f"from the previous step's root nor followed from a small step up to this one "
                f"(continuation in h); {jump}. The step equations have other roots where a step "
                f"is large: IPOPT found one of those, or the physical root does not reach a "
                f"step this large (use more steps).")
    return (f"the replay from its initial state with its controls departs by "
            f"{verdict.replay_q:.2e} of the configurations' span ({verdict.replay_q * q_scale(traj):.3g} "
            f"in their units) and {verdict.replay_p:.2e} of the momenta's size (limit "
            f"{REPLAY_TOLERANCE:g}), first at step {verdict.replay_step}; {jump}. The step "
            f"equations have other roots where a step is large, and IPOPT found one of those.")


def _replay_remedy(traj):
    """What to do about an optimum on another root: on R^n, bounds, prices and a sound
    guess, and for a stage rule (`dmoc.drivers.high_order`) the midpoint rule's optimum on
    twice the steps as its guess; on SO(3), more steps (one rule, a geodesic guess)."""
    if isinstance(traj, RotationTrajectory):
        return "Use more steps, so that no step turns the body by a large angle"
    advice = ("Bound the angles to their physical range (`state_bounds`), price every control "
              "in comparable units (`running_cost`), bound the per-step change of the fast "
              "coordinates, or start from a sound optimum (`guess=`)")
    if not len(traj.stage_nodes):
        return advice
    return (f"{advice}; for this stage rule, the midpoint rule's optimum on twice the steps: "
            f"`guess=dmoc.optimize(problem.with_rule(\"midpoint\").with_steps({2 * traj.steps}))`")
