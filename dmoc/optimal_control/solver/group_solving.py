"""Consumer 2 of the group step residual, its solver: IPOPT on the NLP of a
`GroupOptimalControlProblem` (`group_transcription`), started along the geodesic between
the end rotations, its optimum returned as an OptimizationResult whose trajectory is a
RotationTrajectory.
"""

import time

import numpy as np

from ..._util import checks
from ...errors import failure
from ...mechanics.rotations import orthogonalized
from ...principle.rotation_trajectory import RotationTrajectory
from ..nlp.evaluation import compiled_when_ready, spent
from ..nlp.group_transcription import group_transcription
from ..statement.group_problem import GroupOptimalControlProblem, rotation_vector
from . import interrupt
from .ipopt import iteration_count, start_options
from .ipopt import solver as ipopt_solver
from .optimization_result import OptimizationResult
from .solving import values_at_x


# IPOPT's options for a solve from the geodesic guess (over DEFAULT_IPOPT_OPTIONS):
# - fast_step_computation "yes": each KKT solution as MUMPS returns it, without its residual
#   and the iterative refinement IPOPT does at least once (the option warm starts on R^n
#   take, `ipopt.WARM_START_OPTIONS`). On the group problems of the tests (the sphere roll
#   at N = 20, 40, 80, the slew at N = 10, 40, the quadrotor with and without the cylinder,
#   the spacecraft's move and turn, the falling cat) the same iterations, optima within
#   1e-13, IPOPT's solve 5-15 % faster (one back-solve of the KKT matrix per iteration less).
GUESS_OPTIONS = {"fast_step_computation": "yes"}
# - constr_mult_init_max 0 without path constraints: IPOPT's first multipliers of g zero,
#   without its least-squares estimate. The guess has zero controls and the cost
#   h sum |u_k|^2 has zero gradient there; every row is an equality and no free entry of x
#   has a bound, so the least-squares multipliers, min |grad f + J^T y|, are y = 0 (J of
#   full row rank): the same start, the same iterates, without the estimate's analysis and
#   factorization of another KKT matrix (the rolling ball of tests/optimize/test_sphere_roll.py,
#   N = 20: 12 of the 80 million instructions of IPOPT's solve; the same optimum bit for
#   bit). Path constraints' rows are inequalities, whose slacks' bound multipliers start
#   at 1 and enter the estimate: those keep it.
EQUALITY_GUESS_OPTIONS = {"constr_mult_init_max": 0.0}


def solve_on_group(problem, *, options=None, throw=True, transcription=None):
    """Solve `problem` with IPOPT (exact Hessian), unjudged.

    Parameters
    ----------
    problem : GroupOptimalControlProblem
    options : dict, optional
        IPOPT options over ``DEFAULT_IPOPT_OPTIONS``, `GUESS_OPTIONS` and (without path
        constraints) `EQUALITY_GUESS_OPTIONS`.
    throw : bool
        Raise SolverError when IPOPT fails, Interrupted when a Ctrl-C stopped it (its
        ``.result`` the last iterate, status ``"interrupted"``).
    transcription : GroupTranscription, optional
        `problem`'s (`group_transcription(problem)`, built here when None): given by a
        caller that uses it again (the verdict's replay, `judged_solve_on_group`).

    Returns
    -------
    OptimizationResult
        ``trajectory`` a RotationTrajectory; ``x`` the NLP vector (`GroupTranscription`);
        ``stats``: ``iterations``, ``return_status``, ``max_violation`` (of all rows'
        bounds), ``most_violated`` (that row named: "path constraint i at knot k", "dynamics
        at step k (left row r)", ...; "none"), ``solve_time``, ``warm_start`` (False),
        ``build_time`` (seconds creating the solver, 0 when kept from an earlier solve of
        the structure) and ``compiled`` (whether IPOPT evaluated compiled Functions).
    """
    checks.instance("problem", problem, GroupOptimalControlProblem, "a GroupOptimalControlProblem")
    throw = checks.boolean("throw", throw)
    T = group_transcription(problem) if transcription is None else transcription
    start = {"x0": geodesic_guess(problem, T), "lbx": T.lbx, "ubx": T.ubx}
    guess = {**GUESS_OPTIONS, **(EQUALITY_GUESS_OPTIONS if problem.path_constraints is None else {})}
    return solve_with(problem, T, {**guess, **(options or {})}, start, throw=throw)


def solve_with(problem, T, options, start, *, throw=True, warm_start=False, expand=False, jit=None):
    """One solve of `problem`'s NLP `T` (`group_transcription`) with the IPOPT `options`
    (over DEFAULT_IPOPT_OPTIONS and `start_options`) from `start`, the nlpsol inputs that
    change between solves: ``x0``, ``lbx``, ``ubx`` (q_0 and p_0 fixed there), and for a
    warm start ``lam_x0``, ``lam_g0``; the OptimizationResult of `solve_on_group`, with
    ``lam_x``, ``lam_g`` and ``stats["warm_start"]`` (as given: a receding-horizon
    controller re-solves one structure from the shifted previous optimum,
    `dmoc.drivers.group_horizon`).

    The solver is the one a problem on R^n gets (`dmoc.optimal_control.solver.ipopt.solver`):
    kept per structure and options, evaluating the terms' Functions as `expand` and `jit`
    say (`jit` None: compiled once warm re-solves of the structure have spent
    `COMPILE_AFTER_SECONDS` in IPOPT, `dmoc.optimal_control.nlp.evaluation`)."""
    automatic = jit is None
    if automatic:
        jit = compiled_when_ready(T.separable, warm_start)
    tic = time.perf_counter()
    solver, reused, _ = ipopt_solver(T, {**start_options(warm_start), **options}, expand=expand,
                                     reuse=True, report=False, jit=jit)
    build_time = 0.0 if reused else time.perf_counter() - tic
    zeros_x, zeros_g = np.zeros(T.x_layout.size), np.zeros(T.g_layout.size)
    tic = time.perf_counter()
    with interrupt.watch() as sigints:
        sol = solver(x0=start["x0"], p=T.p, lam_x0=start.get("lam_x0", zeros_x),
                     lam_g0=start.get("lam_g0", zeros_g), lbx=start["lbx"], ubx=start["ubx"],
                     lbg=T.lbg, ubg=T.ubg)
    st = solver.stats()
    cost, (largest, row) = values_at_x(T, sol, st["success"])
    stats = {"iterations": iteration_count(st), "return_status": st["return_status"],
             "max_violation": largest, "most_violated": row,
             "solve_time": time.perf_counter() - tic, "warm_start": warm_start,
             "build_time": build_time, "compiled": jit}
    if automatic and warm_start and not jit:
        spent(T.separable, st.get("t_wall_total", stats["solve_time"]))
    success, status = bool(st["success"]), st["return_status"]
    message = (f"IPOPT: {status} after {stats['iterations']} iterations; most violated: {row} "
               f"(|violation| = {largest:.2e}).")
    interrupted = interrupt.verdict(sigints, stats["iterations"], cost)
    if interrupted is not None:
        (status, message), success = interrupted, False
    x = sol["result_x"]
    result = OptimizationResult(trajectory=trajectory_of(problem, T, x), cost=cost, success=success,
                                status=status, message=message, stats=stats, x=x,
                                lam_x=sol["result_lam_x"], lam_g=sol["result_lam_g"])
    if throw and not success:
        raise failure(message + " The last iterate is in `.result`.", result)
    return result


def geodesic_guess(problem, T):
    """x along the geodesic: R_k (`GroupOptimalControlProblem.geodesic`) and x_k on the
    segment between the ends bent by `bump` (a free goal entry held at its start value),
    both at the shares s_k of the way `timing` gives (k/N, or eased into an end at rest),
    f_k = (cay^{-1}(R_k^T R_{k+1}), x_{k+1} - x_k) (the increments R_k^T R_{k+1} rotate by
    (s_{k+1} - s_k) times the whole turn about its axis: Cayley coordinates 2 tan(angle / 2)
    times the axis), p_k = M(q_k) f_k / h with M the body's `generalized_mass` (diag(J,
    M_x) of a rigid body; the last step's f at N), zero multipliers and controls."""
    N, body = problem.steps, problem.disc.system
    shares = timing(problem)
    R = problem.geodesic(shares)
    M_x = np.array(body.generalized_mass(np.concatenate([problem.R_start.ravel(), problem.x_start])))[3:, 3:]
    motion = np.nan_to_num(problem.x_goal - problem.x_start)          # free goal entries stay
    x = (problem.x_start + np.outer(shares, motion) + np.outer(np.sin(np.pi * shares), bump(M_x, motion)))
    whole = rotation_vector(R[0].T @ R[-1])             # the turn: its angle times its axis
    angle = np.linalg.norm(whole)
    axis = whole / angle if angle > 0 else whole
    turns = 2.0 * np.tan(0.5 * angle * np.diff(shares))[:, None] * axis
    f = np.hstack([turns, np.diff(x, axis=0)])
    q = np.hstack([R.reshape(-1, 9), x])
    n = f.shape[1]
    M = np.array(body.generalized_mass.map(N + 1)(q.T)).reshape(n, N + 1, n).transpose(1, 0, 2)
    p = np.einsum("kij,kj->ki", M, np.vstack([f, f[-1:]]) / problem.disc.h)
    blocks = {"q": q.T, "p": p.T, "f": f.T,
              "lam": np.zeros((body.m, N)), "u": np.zeros((problem.residual.n_controls, N)),
              "nu": np.zeros(body.m)}
    return np.concatenate([blocks[name].ravel(order="F") for name in T.x_layout.blocks])


def timing(problem):
    """The shares s_k of the way at the knots of the default guess, shape (N+1,): the
    quintic s(t) with s(0) = 0, s(1) = 1, s'' = 0 at both ends and s' = 0 at an end where
    the body is at rest (its momentum there zero), 1 elsewhere, at t = k/N; k/N when
    neither end is at rest. A guess at constant speed starts and stops with a jump in
    velocity that the rest-to-rest rows must undo; eased in, IPOPT takes fewer iterations
    (the rolling ball of tests/optimize/test_sphere_roll.py: 7, 10, 11 at N = 20, 40, 80
    from k/N, 6 at each N eased)."""
    t = np.linspace(0.0, 1.0, problem.steps + 1)
    start, end = (float(not np.any(p)) for p in (problem.p_start, problem.p_goal))
    return (10 * t ** 3 - 15 * t ** 4 + 6 * t ** 5                   # s(1) = 1
            + (1.0 - start) * (t - 6 * t ** 3 + 8 * t ** 4 - 3 * t ** 5)    # s'(0) = 1
            + (1.0 - end) * (-4 * t ** 3 + 7 * t ** 4 - 3 * t ** 5))        # s'(1) = 1


def bump(M, motion):
    """The bend 0.1 d / sqrt(M_ii) of each coordinate at the middle of the guess, shape
    (n_x,), d^2 = motion^T M motion the squared length of the motion in the metric of M_x
    (how far coordinate i would move if it made the whole motion), as the default guess on
    R^n bends its chord (`dmoc.optimal_control.solver.guess`): it keeps the guess off a
    mirror symmetry of the problem (a straight flight at an obstacle, whose rows have no
    gradient across the line), and is zero without a motion."""
    return 0.1 * np.sqrt(motion @ M @ motion / np.diag(M))


def trajectory_of(problem, T, x):
    """The RotationTrajectory of the NLP vector x, its R_k made orthogonal to round-off
    (`rotations.orthogonalized`: the NLP holds R_{k+1} = R_k cay(f_k) to IPOPT's final
    violation, up to 1e-13, and each R_k moves by no more than that)."""
    q, p, f, lam, u = (T.x_layout.unpack(x, name).T for name in ("q", "p", "f", "lam", "u"))
    h = problem.disc.h
    return RotationTrajectory.unchecked(h * np.arange(problem.steps + 1), orthogonalized(q[:, :9].reshape(-1, 3, 3)),
                                        p[:, :3], f, u, h, q[:, 9:], p[:, 3:], lam)
