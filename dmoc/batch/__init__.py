"""Many independent solves on dask.distributed, after the two consumers of the step residual:
`optimize_many` runs `optimize` and `simulate_many` runs `simulate` once per input, on a
LocalCluster of this machine, a kept `Cluster` or any Dask scheduler, and returns the
results in input order, each with its own ``success`` and ``status``; no item's failure,
exit or hang reaches another item's result (docs/batch.md, "Failure semantics").

What crosses a process boundary: each problem structure (an OptimalControlProblem, whose
CasADi graphs pickle only inside a CasADi pickle context) or discretization once per
worker, and each item as its data (boundary values, parameters, guess, or a run), in
chunks sized from the measured cost of an item (`shipping`, `tasks`, `item_guard`,
`scheduling`).
"""

try:
    import distributed  # noqa: F401
except ImportError:  # pragma: no cover - depends on the installation
    raise ImportError("dmoc.batch needs dask.distributed: pip install 'dmoc[batch]'.") from None

from .._util import checks
from ..discrete import Discretization, GroupDiscretization
from ..errors import InputError, InputTypeError
from ..optimal_control.statement.problem import OptimalControlProblem
from ..optimal_control.solver.optimization_result import OptimizationResult
from ..principle.trajectory import Trajectory
from ..simulation.time_stepping import SimulationResult
from . import scheduling, shared_memory, shipping, tasks
from .cluster import Cluster
from .failures import BatchInterrupted, SchedulerUnreachable, WorkersFailedToStart
from .tasks import pack_problem, unpack_problem

__all__ = ["optimize_many", "simulate_many", "Cluster", "pack_problem", "unpack_problem",
           "BatchInterrupted", "SchedulerUnreachable", "WorkersFailedToStart"]

KEEP = ("trajectory", "final")     # what simulate_many returns of each run's trajectory

SIMULATE_KEYS = ("q0", "v0", "p0", "steps", "controls", "variant", "tol", "max_iter", "jit")
_SIMULATE_KEYS = frozenset(SIMULATE_KEYS)
REQUIRED_KEYS = ("q0", "steps")     # the keyword arguments `simulate` has no default for
_REQUIRED = frozenset(REQUIRED_KEYS)

CONNECT_TIMEOUT = 5.0


def optimize_many(problems, *, guesses=None, options=None, reuse_solver=True, expand=False,
                  client=None, progress=True, timeout=None, batch_timeout=None,
                  connect_timeout=CONNECT_TIMEOUT):
    """Solve many OptimalControlProblems with `optimize` on Dask workers.

    Each worker gets each problem structure once and keeps its solver; a problem that
    ``with_boundary`` / ``with_parameters`` of one already shipped rebuilds (the same
    NLP, bounds and p) travels as its boundary data and parameter values only. Items go
    in chunks of about 0.5 s of measured work (`dmoc.batch.chunk_sizes`).

    Parameters
    ----------
    problems : sequence of OptimalControlProblem, length B
    guesses : sequence of (Trajectory, OptimizationResult or None), length B, optional
        Warm start of each problem (``optimize(..., guess=)``); None for the default guess.
        A result of a problem of the same `structure` warm-starts IPOPT from its x and
        multipliers, as in `optimize`.
    options : dict, optional
        IPOPT options for every solve (``optimize(..., options=)``).
    reuse_solver, expand : bool
        dmoc's switches of every solve, as `optimize` takes them (a worker keeps the
        solver of each problem structure across the items it solves).
    client : Cluster, distributed.Client or str, optional
        Where to run: by default the scheduler of Dask's configuration
        (``DASK_SCHEDULER_ADDRESS``), else a LocalCluster of ``os.cpu_count()``
        single-threaded worker processes, started for this call and closed after it; a
        `Cluster` or an open Client (left open), or a scheduler address such as
        ``"tcp://10.0.0.1:8786"`` (connected for this call). Whoever can connect to the
        scheduler can run code as its workers' user: docs/batch.md, "Security".
    progress : bool
        Draw a bar of completed solves, the time elapsed and the ETA on stderr.
    timeout : float, optional
        Seconds one item may run on its worker; a longer one becomes a ``"timeout"``
        result and its worker is restarted. None (default): no limit.
    batch_timeout : float, optional
        Seconds the whole call may wait; the items unfinished then become ``"timeout"``
        results. None (default): no limit.
    connect_timeout : float
        Seconds to reach a scheduler given by address (else `SchedulerUnreachable`), and
        the longest the call waits while the scheduler has no worker (the unfinished
        items then become ``"worker_lost"`` results).

    Returns
    -------
    list of OptimizationResult, length B
        In input order, each solved with ``throw=False``: a failed IPOPT run has
        ``success=False`` and IPOPT's status. An item that produced no solve has
        ``trajectory=None``, ``cost=nan``, the reason in ``message`` and one of the
        statuses ``"exception"``, ``"undeserializable"``, ``"worker_lost"``,
        ``"timeout"``, ``"scheduler_lost"`` (the client lost its scheduler before the
        item's result arrived; docs/batch.md, "Failure semantics"). ``stats["worker"]`` is the address of the worker
        that produced the result.

    Raises
    ------
    BatchInterrupted
        On Ctrl-C while waiting (or while the default cluster starts); its ``.results``
        holds the results that had arrived and ``"interrupted"`` ones for the others.
    SchedulerUnreachable, WorkersFailedToStart
        When the batch cannot start at all.
    InputError
        When `client` names no scheduler (an address Dask cannot parse, a ``tls://``
        address without certificates) or is a closed Client.
    """
    problems = _sequence("problems", problems, OptimalControlProblem, "OptimalControlProblem")
    if guesses is None:
        guesses = [None] * len(problems)
    guesses = _sequence("guesses", guesses, (Trajectory, OptimizationResult, type(None)),
                        "Trajectory, OptimizationResult or None")
    if len(guesses) != len(problems):
        raise InputError(f"`guesses` must have one entry per problem ({len(problems)}); "
                         f"got {len(guesses)}.")
    if options is not None:
        options = checks.ipopt_options("options", options)
    timeout = _seconds("timeout", timeout)
    switches = {"reuse_solver": checks.boolean("reuse_solver", reuse_solver),
                "expand": checks.boolean("expand", expand)}
    shipments, items = shipping.problem_items(problems, guesses)
    return _run(tasks.optimize_chunk, (options, switches, timeout), shipments, items,
                OptimizationResult, client, "optimize", progress, batch_timeout, connect_timeout)


def simulate_many(disc, runs, *, keep="trajectory", client=None, progress=True, timeout=None,
                  batch_timeout=None, connect_timeout=CONNECT_TIMEOUT):
    """Run `simulate` once per entry of `runs` on Dask workers.

    Each worker gets each Discretization once (its compiled step is built or loaded once
    per worker process) and each run as its keyword arguments, in chunks as in
    `optimize_many`; the runs of a chunk that share a stepper, h and their number of
    steps step in lockstep (`dmoc.simulation.lockstep`: the results of `simulate` bit for
    bit, for less CPU per run), unless `timeout` is set (then each runs alone).

    A GroupDiscretization (a rigid body on SO(3), `dmoc.simulation.group_stepping`) is
    run the same way, each run alone (no lockstep), its RotationTrajectory sent whole
    with its result: the results of `simulate` bit for bit.

    Parameters
    ----------
    disc : Discretization, GroupDiscretization or sequence of them, length B
        One discretization for every run, or one per run.
    runs : sequence of dict, length B
        Keyword arguments of `simulate` for each run: ``q0``, ``steps`` and one of ``v0``
        or ``p0``; optionally ``controls`` (shape (steps, n_u)), ``variant``, ``tol``,
        ``max_iter``, ``jit``. ``throw`` is always False.
    keep : {"trajectory", "final"}
        What each result's `trajectory` holds: every knot (default), or only the last
        one, t_N, q_N and p_N as a Trajectory of shape (1, n) with no step (on SO(3) a
        RotationTrajectory of R_N, Pi_N, x_N, p_x,N), for sweeps
        that need the end state: a worker then sends about 0.3 kB per run instead of
        80 kB for 1000 steps of the knife edge, whose transfer is a large part of a
        batch of short runs (docs/batch.md). ``stats`` are those of the whole run.
    client, progress, timeout, batch_timeout, connect_timeout
        As in `optimize_many`.

    Returns
    -------
    list of SimulationResult, length B
        In input order; a Newton failure has ``status="newton_failed"`` and the steps
        before it; an item that produced no run has ``trajectory=None`` and one of the
        statuses of `optimize_many`. ``stats["worker"]`` is the worker's address;
        ``stats["wall_time"]`` of a run in lockstep includes its group's other runs.

    Raises
    ------
    BatchInterrupted, SchedulerUnreachable, WorkersFailedToStart
        As in `optimize_many`.
    """
    runs = _sequence("runs", runs, dict, "dict of simulate keyword arguments")
    for i, run in enumerate(runs):
        if not _SIMULATE_KEYS.issuperset(run):      # the message of `no_unknown_keys`
            checks.no_unknown_keys(f"runs[{i}]", run, SIMULATE_KEYS)
        if not _REQUIRED.issubset(run):
            missing = " and ".join(f"`{k}`" for k in REQUIRED_KEYS if k not in run)
            raise InputError(f"`runs[{i}]` must give {' and '.join(f'`{k}`' for k in REQUIRED_KEYS)} "
                             f"of `simulate`; it lacks {missing}.")
    if isinstance(disc, (Discretization, GroupDiscretization)):
        disc = [disc] * len(runs)
    discs = _sequence("disc", disc, (Discretization, GroupDiscretization),
                      "Discretization or GroupDiscretization")
    if len(discs) != len(runs):
        raise InputError(f"`disc` must be one Discretization (or GroupDiscretization) or one "
                         f"per run ({len(runs)}); got {len(discs)}.")
    timeout = _seconds("timeout", timeout)
    keep = checks.choice("keep", keep, KEEP)
    shipments, items = shipping.run_items(discs, runs)
    with shared_memory.Exchange() as share:
        return _run(tasks.simulate_chunk, (timeout, keep, share), shipments, items,
                    SimulationResult, client, "simulate", progress, batch_timeout, connect_timeout)


def _run(task, arguments, shipments, items, kind, client, label, progress, batch_timeout,
         connect_timeout):
    return scheduling.run(task, arguments, shipments, items, kind, client, label=label,
                          progress=checks.boolean("progress", progress),
                          batch_timeout=_seconds("batch_timeout", batch_timeout),
                          connect_timeout=checks.positive_float("connect_timeout",
                                                                connect_timeout))


def _seconds(name, value):
    return None if value is None else checks.positive_float(name, value)


def _sequence(name, values, kinds, described):
    """`values` as a list whose items are instances of `kinds`."""
    if isinstance(values, (str, bytes, dict)) or not hasattr(values, "__len__"):
        raise InputTypeError(f"`{name}` must be a sequence of {described}; got {type(values).__name__}.")
    values = list(values)
    for i, value in enumerate(values):
        if not isinstance(value, kinds):
            raise InputTypeError(f"`{name}` must be a sequence of {described}; "
                                 f"item {i} is a {type(value).__name__}.")
    return values
