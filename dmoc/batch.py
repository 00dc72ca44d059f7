"""Many independent solves on dask.distributed, after the two consumers of the step residual:
`optimize_many` runs `optimize` and `simulate_many` runs `simulate` once per input, on a
LocalCluster of this machine or on any Dask scheduler, and returns the results in input
order, each with its own ``success`` and ``status``.

What crosses a process boundary: an OptimalControlProblem holds CasADi MX expressions
(``problem.nlp``), which pickle only inside a CasADi pickle context, so each problem is
pickled here into bytes (about 150 kB at N = 20, 290 kB at N = 100, without the assembled
derivatives, which the worker rebuilds) and rebuilt on the worker; a Discretization,
guesses (Trajectory) and results pickle as they are.
"""

import os
import sys
import traceback
import uuid

import casadi as ca
import cloudpickle

try:
    import distributed
except ImportError:  # pragma: no cover - depends on the installation
    raise ImportError("dmoc.batch needs dask.distributed: pip install 'dmoc[batch]'.") from None

from ._util import checks
from .discrete import Discretization
from .optimize.problem import OptimalControlProblem
from .optimize.solve import OptimizationResult, optimize
from .simulate.simulation import SimulationResult, simulate
from .principle.trajectory import Trajectory
from .errors import InputError, InputTypeError

# Re-runs of a task whose worker *returned* an error outside dmoc's own call (e.g. its
# arguments failed to deserialize there). A task whose worker dies is rescheduled by the
# scheduler instead, up to `distributed.scheduler.allowed-failures` times (default 3).
RETRIES = 2

SIMULATE_KEYS = ("q0", "v0", "p0", "steps", "controls", "variant", "tol", "max_iter", "jit")


def optimize_many(problems, *, guesses=None, options=None, client=None, progress=True):
    """Solve many OptimalControlProblems with `optimize`, each as one Dask task.

    Parameters
    ----------
    problems : sequence of OptimalControlProblem, length B
    guesses : sequence of (Trajectory or None), length B, optional
        Warm start of each problem (``optimize(..., guess=)``); None for the default guess.
    options : dict, optional
        IPOPT options for every solve (``optimize(..., options=)``).
    client : distributed.Client or str, optional
        Where to run: by default a LocalCluster of ``os.cpu_count()`` single-threaded
        worker processes, started for this call and closed after it; a Client (left open),
        or a scheduler address such as ``"tcp://10.0.0.1:8786"`` (connected for this call).
    progress : bool
        Draw a bar of completed solves on stderr.

    Returns
    -------
    list of OptimizationResult, length B
        In input order, each solved with ``throw=False``: a failed IPOPT run has
        ``success=False`` and IPOPT's status. An exception raised in a task (e.g. a guess
        of the wrong shape) gives ``status="exception"``, and a task whose workers kept
        dying ``status="worker_lost"``; both have ``trajectory=None``, ``cost=nan`` and the
        error in ``message`` (``stats["traceback"]`` for an exception). ``stats["worker"]``
        is the address of the worker that produced the result.
    """
    problems = _sequence("problems", problems, OptimalControlProblem, "OptimalControlProblem")
    if guesses is None:
        guesses = [None] * len(problems)
    guesses = _sequence("guesses", guesses, (Trajectory, type(None)), "Trajectory or None")
    if len(guesses) != len(problems):
        raise InputError(f"`guesses` must have one entry per problem ({len(problems)}); "
                         f"got {len(guesses)}.")
    if options is not None:
        options = checks.ipopt_options("options", options)
    tasks = [(pack_problem(problem), guess, options) for problem, guess in zip(problems, guesses)]
    return _run(_optimize_task, tasks, OptimizationResult, client, progress, "optimize")


def simulate_many(disc, runs, *, client=None, progress=True):
    """Run `simulate` once per entry of `runs`, each as one Dask task.

    Parameters
    ----------
    disc : Discretization or sequence of Discretization, length B
        One discretization for every run, or one per run.
    runs : sequence of dict, length B
        Keyword arguments of `simulate` for each run: ``q0``, ``steps`` and one of ``v0``
        or ``p0``; optionally ``controls`` (shape (steps, n_u)), ``variant``, ``tol``,
        ``max_iter``, ``jit``. ``throw`` is always False.
    client, progress
        As in `optimize_many`.

    Returns
    -------
    list of SimulationResult, length B
        In input order; a Newton failure has ``status="newton_failed"`` and the steps
        before it, an exception (e.g. a wrong shape of ``q0``) ``status="exception"``, a
        task whose workers kept dying ``status="worker_lost"``; both of the latter have
        ``trajectory=None``. ``stats["worker"]`` is the worker's address.
    """
    runs = _sequence("runs", runs, dict, "dict of simulate keyword arguments")
    for i, run in enumerate(runs):
        checks.no_unknown_keys(f"runs[{i}]", run, SIMULATE_KEYS)
    if isinstance(disc, Discretization):
        disc = [disc] * len(runs)
    discs = _sequence("disc", disc, Discretization, "Discretization")
    if len(discs) != len(runs):
        raise InputError(f"`disc` must be one Discretization or one per run ({len(runs)}); "
                         f"got {len(discs)}.")
    return _run(_simulate_task, list(zip(discs, runs)), SimulationResult, client, progress,
                "simulate")


def pack_problem(problem):
    """An OptimalControlProblem as bytes, its CasADi graphs in a pickle context."""
    with ca.global_pickle_context():
        return cloudpickle.dumps(problem)


def unpack_problem(data):
    """The OptimalControlProblem written by `pack_problem`."""
    with ca.global_unpickle_context():
        return cloudpickle.loads(data)


def _optimize_task(data, guess, options):
    try:
        result = optimize(unpack_problem(data), guess=guess, options=options, throw=False)
    except Exception as err:  # any error of one task is that task's result
        result = _failed(OptimizationResult, "exception", f"{type(err).__name__}: {err}",
                         traceback=traceback.format_exc())
    result.stats["worker"] = distributed.get_worker().address
    return result


def _simulate_task(disc, run):
    try:
        result = simulate(disc, **run, throw=False)
    except Exception as err:  # any error of one task is that task's result
        result = _failed(SimulationResult, "exception", f"{type(err).__name__}: {err}",
                         traceback=traceback.format_exc())
    result.stats["worker"] = distributed.get_worker().address
    return result


def _failed(kind, status, message, **stats):
    """A result of `kind` for a task that produced none: no trajectory, success False."""
    if kind is OptimizationResult:
        return OptimizationResult(None, float("nan"), False, status, message, stats, None)
    return SimulationResult(None, False, status, message, stats)


def _run(task, arguments, kind, client, progress, label):
    """Submit task(*args) for each entry of `arguments`; gather the results in input order."""
    progress = checks.boolean("progress", progress)
    client, owned = _connect(client)
    try:
        batch = uuid.uuid4().hex[:8]
        futures = [client.submit(task, *args, key=f"dmoc-{label}-{batch}-{i}", pure=False,
                                 retries=RETRIES) for i, args in enumerate(arguments)]
        order = {future.key: i for i, future in enumerate(futures)}
        results = [None] * len(futures)
        bar = ProgressBar(len(futures), label, sys.stderr if progress else None)
        for future in distributed.as_completed(futures):
            results[order[future.key]] = _gather(future, kind)
            future.release()
            bar.advance()
        bar.close()
        return results
    finally:
        if owned:
            _close(client)


def _gather(future, kind):
    """The future's result, or a `worker_lost` result when the scheduler gave up on it."""
    try:
        return future.result()
    except distributed.KilledWorker as err:
        return _failed(kind, "worker_lost", f"KilledWorker: {err}")


def _connect(client):
    """(Client, whether this call owns it and must close it)."""
    if client is None:
        cluster = distributed.LocalCluster(n_workers=os.cpu_count() or 1, threads_per_worker=1,
                                           processes=True, dashboard_address=":0")
        return distributed.Client(cluster), True
    if isinstance(client, str):
        return distributed.Client(client), True
    if isinstance(client, distributed.Client):
        return client, False
    raise InputTypeError("`client` must be None (a LocalCluster on this machine), a "
                         "distributed.Client or a scheduler address such as 'tcp://host:8786'; "
                         f"got {type(client).__name__}.")


def _close(client):
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()


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


class ProgressBar:
    """A one-line text bar of completed tasks, ``optimize [#####.....] 32/64``.

    Parameters
    ----------
    total : int
    label : str
    stream : file or None
        Where to draw (None: draw nothing).
    """

    WIDTH = 30

    def __init__(self, total, label, stream):
        self.total, self.label, self.stream, self.done = total, label, stream, 0
        self._draw()

    def advance(self):
        self.done += 1
        self._draw()

    def close(self):
        if self.stream is not None:
            self.stream.write("\n")
            self.stream.flush()

    def _draw(self):
        if self.stream is None:
            return
        filled = self.WIDTH * self.done // max(self.total, 1)
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] "
                          f"{self.done}/{self.total}")
        self.stream.flush()
