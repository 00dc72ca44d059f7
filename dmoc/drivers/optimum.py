"""The public `optimize` (a driver): IPOPT's solve judged by the verdict
(`verdict.judged_solve`), with the optimum's discretization error estimated
(`error_estimate`) or the grid refined to an accuracy target (`accuracy`) on request."""

from .._util import checks
from ..errors import failure
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from .accuracy import optimize_to_accuracy
from .error_estimate import estimate_error, with_estimate
from .group_optimum import group_keywords, judged_level_solve


def optimize(problem, *, guess=None, options=None, reuse_solver=True, expand=False,
             linear_solver_report=False, jit=None, throw=True, check=True, estimate=False,
             accuracy=None, max_steps=100_000):
    """Solve a DMOC problem with IPOPT and judge the optimum; optionally estimate its
    discretization error or refine the grid to an accuracy target.

    Parameters
    ----------
    problem : OptimalControlProblem or GroupOptimalControlProblem
        A problem on SO(3) takes `options`, `throw`, `check`, `estimate`, `accuracy` and
        `max_steps` (the others are refused by name); its verdict is
        `dmoc.drivers.group_verdict.judge_on_group` (docs/rigid_bodies.md).
    guess : Trajectory or OptimizationResult, optional
        Initial guess. A Trajectory is resampled in time if its number of steps differs.
        An OptimizationResult of a problem with the same `structure` (the same problem
        with new boundary data or bounds, or a result saved and loaded) warm-starts IPOPT
        from its x and multipliers; any other result is used through its trajectory
        (resampled), IPOPT then estimating the multipliers by least squares there. By
        default the configurations interpolate linearly between the boundary data, bent
        by a small sine bump so the guess avoids points where the constraint Jacobian is
        singular (e.g. the knife edge sliding straight sideways); a free goal entry is
        where the given start velocity carries it over N h (held without one). A stage rule (lobatto3,
        lobatto4) starts instead from the midpoint rule's optimum on the same grid, solved
        from that default guess (`dmoc.drivers.high_order`; ``stats["start"]``); without
        inequalities (bounds, inequality rows, a free final time) only when its solve from
        the default guess fails.
    options : dict, optional
        IPOPT options overriding ``DEFAULT_IPOPT_OPTIONS`` (e.g. ``{"print_level": 5}``).
        Without them, a warm re-solve (`guess` an optimum of the same structure) of a
        problem whose rows are all equalities and whose only bounded entries are the given
        boundary data is solved by Newton's method on its KKT conditions when it converges
        to a strict local minimum, else by IPOPT (``stats["nlp_solver"]``,
        `dmoc.optimal_control.solver.newton_kkt`); given options other than ``tol``,
        ``constr_viol_tol`` and ``print_level``, always by IPOPT.
        Unless given, ``tol`` and ``constr_viol_tol`` are raised from 1e-10 to the rounding
        floor of the rows where the data put it higher (configurations far from the
        origin, docs/stages/optimize.md). Both apply to the scaled NLP
        (`dmoc.optimal_control.nlp.scaling`): the rows in momentum units count divided by the
        inertia, so with m = 1e5 a
        ``constr_viol_tol`` of 1e-6 admits momentum rows violated by 0.1 in the system's
        units (relative to momenta of size m v); ``stats["max_violation"]`` is in the
        system's units. The entries ``"reuse_solver"``, ``"expand"`` and
        ``"linear_solver_report"`` are deprecated (a DeprecationWarning): they are taken
        as the keywords of those names.
    reuse_solver : bool
        True (default): take the solver of an earlier problem of the same structure and
        options from the cache; False builds a fresh one, dropped after the call.
    expand : bool
        True evaluates the NLP's five Functions (f, g and the derivatives assembled from
        the terms, ``problem.transcription.separable.functions()``) as flat SX Functions
        instead of the MX graph of mapped terms: the same operations, so the same optimum
        and iterations, faster per evaluation (g and the Jacobian least) and slower to
        build, the more so as N grows (`dmoc.optimal_control.nlp.evaluation`;
        benchmarks/peers.py resolve, "raw SX"). For re-solves without a C compiler; `jit`
        is faster still. Default False.
    linear_solver_report : bool
        True adds ``stats["linear_solver"]``, what the KKT factorizations needed, read from
        IPOPT's detailed journal (`dmoc.optimal_control.solver.linear_solver`); writing it adds 10-30 %
        to the solve. Default False.
    jit : bool or None
        True evaluates the NLP (objective, constraints and their derivatives) as C code,
        compiled once per NLP structure with the system's C compiler and kept on disk
        across processes in the private folder of the simulator's compiled steps
        (`dmoc.optimal_control.nlp.evaluation`; an error without a C compiler). The same operations as
        in CasADi's virtual machine, so the same optimum and iterations, 2-6 times
        faster per evaluation; compiling takes about 1-3 s the first time, loading the
        library tens of milliseconds once per process. None (default): the virtual
        machine until the structure's warm re-solves (starts from an earlier optimum of
        the same structure) have spent 0.1 s in IPOPT, which starts compiling it in a
        background thread; its solves after the library is loaded evaluate the C code
        (``stats["compiled"]``; without a C compiler, never). False: never compile, nor
        the light verdict's step (docs/stages/optimize.md, "Compiled re-solves").
    throw : bool
        Raise SolverError when IPOPT fails or its optimum fails the verdict, and
        `dmoc.Interrupted` when a Ctrl-C (SIGINT) stops it (default); else return the
        result with success=False (status ``"interrupted"`` after a Ctrl-C, the verdict's
        status after a failed verdict). Either way the error's `.result` holds the last
        iterate or the judged optimum with its `verdict`.
    check : bool
        True (default): judge the optimum IPOPT converged to (`judge`): the replay by
        `simulate`, the velocity jumps, the path constraints at the knots, and on SO(3) the
        last knot at the goal (`dmoc.drivers.group_verdict.judge_on_group`). False: IPOPT's
        verdict only, for callers that judge themselves (an MPC's re-solves); the same as
        the raw `dmoc.optimal_control.solve`.
    estimate : bool
        True: estimate the optimum's discretization error
        (`dmoc.drivers.error_estimate.estimate_error`: a solve on N/2 steps started from the
        optimum and a replay on 2N steps; its cost against the solve:
        benchmarks/accuracy.py --estimates) into ``verdict.discretization_error`` and
        ``stats["error_estimate"]``; a passed verdict becomes ``"under_resolved"`` when the
        estimated end error exceeds a quarter of the coordinates' excursion
        (`dmoc.drivers.error_estimate.UNRESOLVED_END`). Default False.
    accuracy : float, optional
        A relative target in [1e-9, 1) for the estimated error of the cost and of the
        re-simulated final state: the grid is refined from ``problem.steps``, each level
        started from the last (`dmoc.drivers.accuracy.optimize_to_accuracy`), and the last
        level's result returned with ``stats["levels"]``. Start coarse (N of 10 to 20 with
        a stage rule).
    max_steps : int
        With `accuracy`, the largest N a level may have (status
        ``"accuracy_not_reached"`` beyond it).

    Returns
    -------
    OptimizationResult
        ``success`` is True only when IPOPT converged and, with `check`, the verdict
        passed (and, with `accuracy`, the target was reached); ``verdict`` holds the
        checks' figures.

    Notes
    -----
    The solver (``casadi.nlpsol``) takes its gradient, constraint Jacobian and Hessian of
    the Lagrangian from ``problem.transcription.separable.derivatives()`` (exact,
    assembled from each term's derivatives) instead of generating them for the whole
    graph. IPOPT iterates on the NLP scaled by the system's inertia
    (``problem.transcription.x_scale`` and ``g_scale``, `dmoc.optimal_control.nlp.scaling`); the start point, the bounds and the multipliers are converted on the
    way in and out, so guesses and results are in the system's units. It is created
    once per problem structure and options and kept in a bounded cache: boundary data,
    bounds, the parameters (h, q_ref) and the guess are solver inputs, so re-solving the
    same problem, or one from ``problem.with_boundary(...)``, skips the
    build. A warm start (IPOPT's ``warm_start_init_point``) starts from the previous
    optimum's multipliers; every other start lets IPOPT estimate them, with a second solver
    of the same structure (its creation reuses the assembled derivatives, so it is cheap
    next to the first build).

    A converged NLP can fail to replay: the step equations have other roots when a step
    is large, and IPOPT may converge to one of those (docs/stages/drivers.md,
    "Verdicts"). A failed verdict raises with `throw` as an IPOPT failure does, so that
    no caller uses such an optimum unawares; ``err.result`` keeps it for a look or as a
    guess.
    """
    if isinstance(problem, GroupOptimalControlProblem):
        keywords = group_keywords(options=options, throw=throw, check=check, guess=(guess, None),
                                  reuse_solver=(reuse_solver, True), expand=(expand, False),
                                  jit=(jit, None),
                                  linear_solver_report=(linear_solver_report, False))
    else:
        keywords = {"options": options, "reuse_solver": reuse_solver, "expand": expand,
                    "linear_solver_report": linear_solver_report, "jit": jit, "throw": throw,
                    "check": check}
    estimate = checks.boolean("estimate", estimate)
    if accuracy is not None:
        return optimize_to_accuracy(problem, accuracy, guess=guess, max_steps=max_steps,
                                    **keywords)
    result = judged_level_solve(problem, guess=guess, **keywords)
    if not (estimate and result.success):
        return result
    result = with_estimate(result, estimate_error(problem, result, **keywords))
    if throw and not result.success:        # the estimate found the grid too coarse
        raise failure(result.message + " The optimum is in `.result`.", result)
    return result
