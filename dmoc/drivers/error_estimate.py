"""The error estimate, a driver (issue 23): `estimate_error`, the discretization error
of a DMOC optimum's cost and of its re-simulated final state by Richardson extrapolation
with the order p of the discretization, J_N - J ~ (J_N - J_M) / (1 - (N / M)^p) from a
solve on a coarser grid and q_N - q(T) ~ (q_N - q_2N) / (1 - 2^-p) from a replay on a
finer one, as an `ErrorEstimate` that `with_estimate` records in a result
(docs/stages/drivers.md, "Accuracy targets and error estimates")."""

import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from .._util import checks
from ..discrete.rules import lagrange_basis
from ..errors import InputError
from ..optimal_control import OptimalControlProblem, OptimizationResult
from ..simulation import simulate
from .verdict import judged_solve


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
        Passed to IPOPT's solve (`dmoc.optimal_control.solve`: ``options``, ...); the reference
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
    benchmarks/accuracy.py --estimates); the replay, a simulation of 2N steps.

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
    return richardson_estimate(problem, result, reference, tic)


def richardson_estimate(problem, result, reference, tic):
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

def with_estimate(result, estimate):
    """`result` with `estimate` (an ErrorEstimate) in ``stats["error_estimate"]`` (plain
    numbers and lists, so `OptimizationResult.save` keeps it) and its largest figure in
    ``verdict.discretization_error`` where the result was judged."""
    stats = {**result.stats, "error_estimate": {**asdict(estimate),
                                                "state_error": estimate.state_error.tolist()}}
    verdict = result.verdict if result.verdict is None else \
        replace(result.verdict, discretization_error=estimate.largest)
    return replace(result, stats=stats, verdict=verdict)
