"""The verdict on an optimum on SO(3) x R^n_x (a driver): `judge_on_group` checks what IPOPT
returned for a `GroupOptimalControlProblem` as `dmoc.drivers.verdict.judge` checks an
optimum on R^n, with the same figures and thresholds (`verdict_checks`): the replay of its
controls by the group step residual the simulator solves, its last knot at the goal (by the
angle of R_goal^T R_N), its path rows g(R_k, x_k, u_k) at every knot and the jumps of its
velocities (Omega, x') at the knots (docs/rigid_bodies.md, "The verdict on the group")."""

import casadi as ca
import numpy as np

from .._util import checks
from ..errors import InputError, Status
from ..optimal_control.solver.optimization_result import OptimizationResult
from ..optimal_control.solver.verdict_record import Verdict
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from ..optimal_control.statement.parameters import expression_texts
from ..principle.rotation_trajectory import RotationTrajectory
from ..results.knot_velocities import relative_changes
from ..simulation.time_stepping import simulate
from .group_replay import nlp_replay
from .verdict_checks import (GOAL_TOLERANCE, JUMP_LIMIT, PATH_TOLERANCE, REPLAY_TOLERANCE,
                             largest_change, path_violation, replay_departure, scale, worst_status)


def judge_on_group(problem, result, transcription=None):
    """The Verdict on an optimum of a problem on SO(3) x R^n_x.

    Parameters
    ----------
    problem : GroupOptimalControlProblem
    result : OptimizationResult
        An optimum of `problem`: its trajectory a RotationTrajectory on ``problem.steps``.
    transcription : GroupTranscription, optional
        `problem`'s, when the caller has it (the solve's); else built for the replay.

    Returns
    -------
    Verdict
        Its status the worst failed check of ``"not_replayable"``, ``"goal_missed"``,
        ``"path_violated"`` and ``"under_resolved"``, or ``"passed"``; the figures as on
        R^n (`dmoc.optimal_control.solver.verdict_record.Verdict`), with ``goal_error``.

    Notes
    -----
    The replay solves the step rows from (R_0, x_0, p_0) with the optimum's controls, held
    on each step, in CasADi's virtual machine: Newton's method on the NLP's own step term
    with the Jacobian its solve built (`group_replay.nlp_replay`: the group step residual
    the simulator solves, the same warm starts, converged to its tolerance), or, when a
    step does not converge there, `dmoc.simulate` (``jit=False``, as on R^n,
    `dmoc.diagnostics.replay`: preparing the compiled step costs more than the N steps of
    an optimum), and compares every q_k (the entries of R_k, then x_k) and p_k = (Pi_k,
    p_x,k) (the end momentum included: the end impulse enters no step). The goal error is
    the larger of the angle 2 arcsin(|R_N - R_goal|_F / sqrt(8)) of R_goal^T R_N, accurate
    near 0 where arccos((tr - 1)/2) is not, and max_i |x_N,i - x_goal,i| over the span of
    x (`scale`). The path rows are the NLP's g(R_k, x_k, u_k), k = 0 ... N (u_{N-1} at
    q_N). The velocities of the step's curve R_k cay(c f_k) (`RotationTrajectory.sample`)
    are Omega = f_k / h at its start and f_k / (h (1 + |f_k|^2 / 4)) at its end, x' =
    dx_k / h at both, all in the body frame at the knot they meet, so their jumps
    (`relative_changes`) compare like with like. Not checked: the end velocity (its rows
    p_N = p_goal + A^T nu carry the impulse nu, which the replay does not see) and the
    velocity bounds, end conditions and stage-rule roots that a problem on SO(3) does not
    have.
    """
    checks.instance("problem", problem, GroupOptimalControlProblem, "a GroupOptimalControlProblem")
    checks.instance("result", result, OptimizationResult, "an OptimizationResult")
    traj = checks.instance("result.trajectory", result.trajectory, RotationTrajectory,
                           "a RotationTrajectory")
    if traj.steps != problem.steps:
        raise InputError(f"`result` must be an optimum of `problem` ({problem.steps} steps); "
                         f"got one on {traj.steps} steps.")
    replay = nlp_replay(problem, traj, transcription=transcription)
    if replay is None:              # a step Newton did not converge: the simulator's replay
        q0 = (traj.R[0], traj.x[0]) if problem.disc.system.n_x else traj.R[0]
        replay = simulate(problem.disc, q0=q0, p0=traj.p[0], steps=problem.steps, controls=traj.u,
                          throw=False, jit=False).trajectory
    replay_q, replay_p, replay_step = replay_departure(traj, replay, traj.steps + 1)
    goal = goal_error(problem, traj)
    path, path_step, row, limit = path_violation(
        group_knot_path_values(problem, traj),
        lambda row: f"path_constraints row {row} ({_row_texts(problem)[row]} <= 0)")
    jump, jump_step, coordinate = largest_change(
        relative_changes(*group_end_velocities(traj)) if traj.steps > 1 else np.zeros((0, 0)),
        [f"Omega_{i}" for i in range(3)] + [f"x_{i}" for i in range(problem.disc.system.n_x)])
    status = worst_status({Status.NOT_REPLAYABLE: max(replay_q, replay_p) > REPLAY_TOLERANCE,
                           Status.GOAL_MISSED: goal > GOAL_TOLERANCE,
                           Status.PATH_VIOLATED: path > PATH_TOLERANCE,
                           Status.UNDER_RESOLVED: jump > JUMP_LIMIT})
    return Verdict(status, replay_q, replay_p, replay_step, jump, jump_step, coordinate, path,
                   path_step, row, path_limit=limit, goal_error=goal)


def goal_error(problem, traj):
    """max(angle of R_goal^T R_N in radians (0 when R_goal is free), max_i |x_N,i -
    x_goal,i| / span of x over the given entries of x_goal) of the optimum `traj`
    (`judge_on_group`)."""
    chord = 0.0 if problem.R_goal is None else np.linalg.norm(traj.R[-1] - problem.R_goal) / np.sqrt(8.0)
    angle = 2.0 * np.arcsin(min(chord, 1.0))
    if not problem.disc.system.n_x:
        return float(angle)
    span = scale(np.ptp(traj.x, axis=0).max(), np.abs(traj.x).max())
    given = np.isfinite(problem.x_goal)
    return max(float(angle), float(np.abs(traj.x[-1] - problem.x_goal)[given].max(initial=0.0) / span))


def group_knot_path_values(problem, traj):
    """The path constraints g(R_k, x_k, u_k) of `problem` at every knot of `traj`, shape
    (N + 1, rows), u_{N-1} at q_N: the values the NLP's ``path_knots`` rows impose
    (`dmoc.optimal_control.nlp.group_transcription`); (N + 1, 0) without path constraints."""
    if problem.path_constraints is None:
        return np.zeros((traj.steps + 1, 0))
    u = np.vstack([traj.u, traj.u[-1:]])
    mapped = problem.path_constraints.map(traj.steps + 1)
    R = np.transpose(traj.R, (0, 2, 1)).reshape(-1, 3).T      # the R_k side by side, (3, 3(N + 1))
    return np.array(mapped(R, traj.x.T, u.T)).T


def group_end_velocities(traj):
    """The velocities (Omega, x') of each step's curve at its start and its end, shapes (N, 3 +
    n_x) each (`judge_on_group`)."""
    f, h = traj.f, traj.h
    shrink = 1.0 + 0.25 * np.sum(f[:, :3] ** 2, axis=1, keepdims=True)
    start = f / h
    end = np.hstack([f[:, :3] / (h * shrink), f[:, 3:] / h])
    return start, end


def _row_texts(problem):
    """The rows of the path constraints as the user wrote them, with R_ij, x_i and u_i."""
    R = ca.SX(3, 3)
    for i in range(3):
        for j in range(3):
            R[i, j] = ca.SX.sym(f"R_{i}{j}")
    x, u = (ca.vertcat(*[ca.SX.sym(f"{name}_{i}") for i in range(size)]) if size else ca.SX(0, 1)
            for name, size in (("x", problem.disc.system.n_x), ("u", problem.disc.n_controls)))
    return expression_texts(problem.path_constraints(R, x, u))
