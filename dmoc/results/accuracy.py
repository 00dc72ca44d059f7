"""The results stage's accuracy tools (issue 23): `estimate_error`, the discretization
error of a DMOC optimum's cost and of its re-simulated final state by Richardson
extrapolation with the rule's order (a solve on a coarser grid, a replay on a finer one),
and `optimize_to_accuracy`, which refines the grid until that estimate is below a target,
each level warm-started from the last (docs/stages/optimize.md, "Accuracy targets and
error estimates")."""

import math
import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from .._util import checks
from ..discrete.rules import lagrange_basis
from ..errors import InputError, SolverError
from ..optimize import OptimalControlProblem, OptimizationResult
from ..simulate import simulate
from .verdict import judged_solve

# Targets below this are refused: the estimate is a difference of costs that IPOPT (tol
# 1e-10 on the scaled NLP) and round-off know to about 1e-10 relative.
SMALLEST_ACCURACY = 1e-9
# A level multiplies N by at most this, whatever a pre-asymptotic estimate predicts.
GROWTH = 16


@dataclass(frozen=True)
class ErrorEstimate:
    """The estimated discretization error of an optimum on N steps (`estimate_error`).

    Attributes
    ----------
    cost : float
        |J_N - J| / |J_N|: J_N the optimum's cost, J the continuous problem's (absolute
        where J_N = 0).
    final_state : float
        max_i |q_N,i - q_i(T)| / range_i: q(T) the end of the continuous flow driven by
        the optimum's controls from its start, range_i the excursion of coordinate i over
        the optimum (1 where it does not move), so that the figure does not depend on
        units. The momentum p_N is left out: it differs from p(T) by a constraint impulse
        A(q_N)^T mu of the order of the step (measured on the knife edge and the disk)
        that changes no allowed velocity.
    cost_error : float
        The signed estimate of J_N - J.
    state_error : ndarray, shape (n,)
        The signed estimate of q_N - q(T).
    order : int
        The order p the extrapolation assumes: the discretization's (`Discretization.order`,
        which is lower than the rule's for stage rules on degenerate Lagrangians).
    steps, reference_steps : int
        N, and the steps of the solve whose cost was compared with the optimum's.
    time : float
        Wall seconds spent on the estimate (0 for the reference solve when it was given).
    """

    cost: float
    final_state: float
    cost_error: float
    state_error: np.ndarray
    order: int
    steps: int
    reference_steps: int
    time: float

    @property
    def largest(self):
        """max(cost, final_state), the figure an accuracy target bounds."""
        return max(self.cost, self.final_state)


def estimate_error(problem, result, *, reference=None, **keywords):
    """Estimate the discretization error of the optimum `result` of `problem` (Richardson
    extrapolation with the rule's order).

    Parameters
    ----------
    problem : OptimalControlProblem
        The problem `result` solves, on N steps.
    result : OptimizationResult
        Its optimum.
    reference : OptimizationResult, optional
        An optimum of the same problem on M != N steps (``problem.with_steps(M)``). By
        default the problem is solved on M = N // 2 steps (2 when N = 1), started from
        `result`'s trajectory.
    **keywords
        Passed to IPOPT's solve (`dmoc.optimize.solve`: ``options``, ...); the reference
        is not judged and does not raise: a failed one gives an infinite estimate.

    Returns
    -------
    ErrorEstimate

    Notes
    -----
    A rule of order p gives J_N = J + C N^-p + o(N^-p), so two costs give
    J_N - J ~ (J_N - J_M) / (1 - (N / M)^p). The final state is the re-simulated one:
    `simulate` drives the system from the optimum's (q_0, p_0) by its controls (each
    step's interpolant, `Trajectory.control`) on 2N steps of the same rule and variant;
    its end q_2N and the optimum's q_N (at the goal) give q_N - q(T) ~ (q_N - q_2N) /
    (1 - 2^-p). The reference solve costs about a solve on M steps (`ErrorEstimate.time`;
    docs/performance.md); the replay, a simulation of 2N steps.

    Examples
    --------
    >>> import dmoc, dmoc.problems
    >>> problem = dmoc.problems.knife_edge_parking(20, rule="lobatto3")
    >>> result = dmoc.optimize(problem, options={"print_level": 0, "sb": "yes"})
    >>> estimate = estimate_error(problem, result, options={"print_level": 0, "sb": "yes"})
    >>> estimate.reference_steps, f"{estimate.cost:.0e}"     # J* = 8.72240586430: 3.5e-06
    (10, '2e-06')
    """
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    checks.instance("result", result, OptimizationResult, "an OptimizationResult")
    _check_steps(problem, result)
    tic = time.perf_counter()
    if reference is None:
        keywords.update(check=False, throw=False)      # a failed reference: an infinite estimate
        reference = judged_solve(problem.with_steps(problem.steps // 2 or 2),
                                 guess=result.trajectory, **keywords)
    checks.instance("reference", reference, OptimizationResult, "an OptimizationResult or None")
    if reference.trajectory.steps == problem.steps:
        raise InputError(f"`reference` must be an optimum on another number of steps than "
                         f"`result` ({problem.steps}); got one on {reference.trajectory.steps}.")
    return _estimate(problem, result, reference, tic)


def _estimate(problem, result, reference, tic):
    """The ErrorEstimate of `result` against `reference`, timed from `tic`."""
    p, N, M = problem.disc.order, problem.steps, reference.trajectory.steps
    cost_error = np.inf if not reference.success else \
        (result.cost - reference.cost) / (1.0 - (N / M) ** p)
    end, scale = _end_state(result.trajectory)
    state_error = (end - _replayed_end(problem, result.trajectory)) / (1.0 - 2.0 ** -p)
    return ErrorEstimate(abs(cost_error) / (abs(result.cost) or 1.0),
                         float(np.max(np.abs(state_error) / scale)), float(cost_error),
                         state_error, p, N, M, time.perf_counter() - tic)


def _check_steps(problem, result):
    if result.trajectory.steps != problem.steps:
        raise InputError(f"`result` must be an optimum of `problem` ({problem.steps} steps); "
                         f"got one on {result.trajectory.steps} steps.")


def _end_state(traj):
    """(q_N, the excursion of each coordinate over the trajectory; 1 where none)."""
    excursion = np.ptp(traj.q, axis=0)
    return traj.q[-1], np.where(excursion > 0, excursion, 1.0)


def _replayed_end(problem, traj):
    """The end of `simulate` over 2N steps from the optimum's (q_0, p_0), driven by its
    controls: each step's Lagrange interpolant of its values at the control nodes, read
    at the half steps' nodes (the end of a step's own polynomial, not the next step's).
    In CasADi's virtual machine, as the verdict's replay (`dmoc.diagnostics.replay`), so
    that both use one step Function of this rule and variant."""
    nodes = np.asarray(problem.disc.rule.control_nodes)
    halves = np.concatenate([nodes / 2, (1 + nodes) / 2])        # the half steps' nodes
    weights = lagrange_basis(nodes, halves)[0]                   # (2 k, k)
    n_u, N = problem.disc.system.n_u, traj.steps
    u = traj.u.reshape(N, len(nodes), n_u)
    controls = np.einsum("jk,skc->sjc", weights, u).reshape(2 * N, -1)
    run = simulate(problem.disc.with_step(traj.h / 2), q0=traj.q[0], p0=traj.p[0], steps=2 * N,
                   controls=controls, variant=traj.variant, throw=False, jit=False)
    if not run.success:
        return np.full(traj.q.shape[1], np.inf)     # it does not replay
    return run.trajectory.q[-1]


def optimize_to_accuracy(problem, accuracy, *, guess=None, max_steps=100_000, **keywords):
    """Solve `problem` on finer and finer grids until the estimated relative error of its
    cost and of its re-simulated final state is below `accuracy` (`estimate_error`).

    Parameters
    ----------
    problem : OptimalControlProblem
        The first level: its N and rule. Start coarse (N of 10 to 20 with a stage rule):
        the first two levels only measure the error.
    accuracy : float
        The target of `ErrorEstimate.largest`, relative: of the cost to |J|, of each
        coordinate of the final configuration to its excursion over the optimum. In
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
        `ErrorEstimate.largest`; None on the first level) and ``time``, wall seconds of
        the level's problem, solve and estimate) and ``stats["error_estimate"]`` (the last
        `ErrorEstimate` as a dict of plain numbers and lists, so `OptimizationResult.save`
        keeps it).

    Raises
    ------
    SolverError
        A level's solve failed, or the target needs more than `max_steps` steps, with
        ``throw=True`` (the default); ``.result`` is the last level's. With ``throw=False``
        the result comes back with ``success=False``.

    Notes
    -----
    Level 2 has 2N steps; then the error C N^-p measured at N_k predicts the N at which
    it is half the target, N_{k+1} = N_k (2 e_k / accuracy)^(1/p), at most ``GROWTH``
    N_k, and each level's estimate compares its cost with the level before. Every level
    is judged (`dmoc.results.verdict`); one the verdict finds under-resolved is refined
    to 2N like the first, any other failure ends the loop. The rule stays the problem's:
    a higher order reaches small targets on far fewer steps (docs/performance.md).
    """
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    accuracy = _accuracy(accuracy)
    max_steps = checks.positive_int("max_steps", max_steps)
    levels, level, previous, tic = [], problem, None, time.perf_counter()
    while True:
        result = judged_solve(level, guess=guess if previous is None else previous.trajectory,
                              **{**keywords, "throw": False})
        coarse = result.status == "under_resolved"      # what more steps cure: refine
        estimate = None if previous is None or not result.success else \
            _estimate(level, result, previous, time.perf_counter())
        levels.append(_level_record(level, result, estimate, time.perf_counter() - tic))
        tic = time.perf_counter()
        if not (result.success or coarse) or (estimate is not None and estimate.largest <= accuracy):
            return _finished(result, levels, estimate, accuracy, keywords)
        steps = 2 * level.steps if estimate is None else _next_steps(level.steps, estimate, accuracy)
        if steps > max_steps:
            return _finished(result, levels, estimate, accuracy, keywords, max_steps)
        level, previous = level.with_steps(steps), result


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
    return {"steps": problem.steps, "rule": problem.disc.rule.name, "cost": result.cost,
            "status": result.status, "iterations": result.stats["iterations"],
            "estimate": None if estimate is None else estimate.largest, "time": seconds}


def _finished(result, levels, estimate, accuracy, keywords, max_steps=None):
    """The last level's result with the levels and the estimate in its stats; status
    ``"accuracy_not_reached"`` when `max_steps` stopped the loop; SolverError with throw
    when it failed."""
    result = replace(result, stats={**result.stats, "levels": levels})
    if estimate is not None:
        result = with_estimate(result, estimate)
    stats = result.stats
    if max_steps is None and not result.success:        # a level failed its solve or verdict
        if keywords.get("throw", True):
            raise SolverError(result.message + " The last level's result is in `.result`.",
                              result)
        return result
    if max_steps is None:
        message = (
            f"{result.message} Accuracy {accuracy:g} reached on {levels[-1]['steps']} steps "
            f"({levels[-1]['rule']}) after {len(levels)} levels: estimated relative error "
            f"{estimate.cost:.1e} of the cost, {estimate.final_state:.1e} of the final state.")
        return replace(result, stats=stats, message=message)
    figure = "not yet estimated" if estimate is None else f"{estimate.largest:.1e}"
    message = (f"Accuracy {accuracy:g} not reached: the estimated relative error is "
               f"{figure} on {levels[-1]['steps']} steps and the next level "
               f"would need more than `max_steps` = {max_steps}; raise `max_steps` or use a "
               f"rule of higher order (lobatto3, lobatto4).")
    result = replace(result, success=False, status="accuracy_not_reached", message=message,
                     stats=stats)
    if keywords.get("throw", True):
        raise SolverError(message + " The last level's optimum is in `.result`.", result)
    return result


def with_estimate(result, estimate):
    """`result` with `estimate` (an ErrorEstimate) in ``stats["error_estimate"]`` (plain
    numbers and lists, so `OptimizationResult.save` keeps it) and its largest figure in
    ``verdict.discretization_error`` where the result was judged."""
    stats = {**result.stats, "error_estimate": {**asdict(estimate),
                                                "state_error": estimate.state_error.tolist()}}
    verdict = result.verdict if result.verdict is None else \
        replace(result.verdict, discretization_error=estimate.largest)
    return replace(result, stats=stats, verdict=verdict)
