"""The worker side of a batch: a problem structure or a discretization arrives once per
worker (`Shipment`, a worker plugin, so a worker that joins or restarts later gets it too),
and each task runs `optimize` or `simulate` (the two consumers of the step residual) on a
chunk of items that carry their data only, on the worker's kept solver or compiled step.
Every item gets a result of its own, whatever it does.

Each item unpickles its own data, and the shipped object is unpickled inside the item's
guard, so an argument the worker cannot load (a class only the client can import) is that
item's ``"undeserializable"`` result and not an error of the worker. Everything an item
raises, `SystemExit` and `KeyboardInterrupt` included, is caught, so one item cannot end
the worker process that runs its neighbours. With a per-item timeout each item runs in a
thread of its own, which the task abandons when the time is up; the task then returns
the results so far and the client queues the chunk's other items again; so does a chunk
sent with a CPU budget (before any item's cost is measured) once it has spent it.
"""

import math
import time

import casadi as ca
import cloudpickle
import distributed
import numpy as np

from .._util.cache import BoundedCache
from ..errors import Status
from .item_guard import attempt, caught, guarded, guarded_chunk, in_turn, stamp
from .packing import ChunkMemory, PackedResults
from ..optimal_control.solver.optimization_result import OptimizationResult
from ..discrete.group_discretization import GroupDiscretization
from ..principle.rotation_trajectory import RotationTrajectory
from ..principle.trajectory import Trajectory
from ..optimal_control.solver.solving import solve as ipopt_solve
from ..drivers.verdict import judge, judged, verdicts
from ..simulation.lockstep import simulate_lockstep
from ..simulation.preparation import Run, prepare_runs
from ..simulation.time_stepping import SimulationResult, simulate

# digest -> [the Shipments registered with it, their bytes] in this worker process, while
# a batch runs (not a BoundedCache: `clear_caches` must not empty it)
_SHIPPED = {}
_LOADED = BoundedCache(8, "batch shipments")     # digest -> the unpickled problem or disc


def pack_problem(problem):
    """An OptimalControlProblem as bytes, its CasADi graphs in a pickle context."""
    with ca.global_pickle_context():
        return cloudpickle.dumps(problem)


def unpack_problem(data):
    """The OptimalControlProblem written by `pack_problem`."""
    with ca.global_unpickle_context():
        return cloudpickle.loads(data)


class Shipment(distributed.WorkerPlugin):
    """The bytes of one problem (`pack_problem`) or discretization (cloudpickle), kept by
    every worker of the cluster under their `digest` while the batch runs: registered
    once per batch, set up on each worker now and on every worker that joins later
    (restarted ones too), torn down when the batch unregisters it. Batches that ship the
    same bytes at once share them until the last one ends."""

    def __init__(self, digest, data):
        self.digest, self.data = digest, data

    def setup(self, worker):
        _SHIPPED.setdefault(self.digest, [0, self.data])[0] += 1

    def teardown(self, worker):
        entry = _SHIPPED.get(self.digest)
        if entry is not None:
            entry[0] -= 1
            if entry[0] <= 0:
                del _SHIPPED[self.digest]


def shipped(digest, unpack):
    """The object shipped under `digest`, unpacked once per worker process by `unpack`."""
    if digest not in _SHIPPED:
        raise LookupError(f"nothing was shipped to this worker under {digest!r}")
    return _LOADED.get(digest, lambda: unpack(_SHIPPED[digest][1]))


def optimize_chunk(digest, items, options, switches, timeout, budget=None):
    """For each item, ``shipping.pickled((boundary, parameter_values, guess))``:
    `optimize` on the shipped problem with that boundary data (``with_boundary``) and
    those parameter values (``with_parameters``), ``throw=False``; never raises for an
    item. Returns (results, seconds per item), results possibly fewer than items: a
    timeout ends the chunk, and so does the item that spends the `budget` (CPU seconds of
    the chunk; None: no limit), which the client sets while it knows no item's cost.

    Without a `timeout`, IPOPT solves the items one by one and the optima it converged
    to are judged together (`_judged`: `dmoc.drivers.verdict.verdicts`, the same verdicts
    as one by one, for less CPU); each item's seconds are its solve's CPU seconds and its
    share of the verdicts'. With a `timeout`, each item is solved and judged alone, in a
    thread the task can abandon."""
    def solver(item):
        def load():
            return shipped(digest, unpack_problem), cloudpickle.loads(item)

        def solve(loaded):
            problem, (boundary, values, guess) = loaded
            problem = problem.with_boundary(**boundary)
            if values:
                problem = problem.with_parameters(**values)
            return problem, ipopt_solve(problem, guess=guess, options=options, **switches,
                                        throw=False)
        return load, solve

    calls = [solver(item) for item in items]
    if timeout is None:
        return _solved_then_judged(calls, budget)
    return guarded_chunk(OptimizationResult, [(load, lambda loaded, solve=solve: _judged([solve(loaded)])[0])
                                       for load, solve in calls], timeout, budget)


def _solved_then_judged(calls, budget):
    """(results, seconds) of the (load, solve) `calls` of `optimize_chunk` without a
    timeout: each item loaded and solved in its own guard (`in_turn`), up to and
    including the item that spends the `budget` (None: no limit), then the optima judged
    together (`_judged`); each result stamped with this worker's address. An item's
    seconds are the CPU seconds of its solve and an equal share of the verdicts'."""
    solved, seconds = in_turn(OptimizationResult, calls, None, budget)
    tic = time.process_time()
    results = _judged(solved)
    share = (time.process_time() - tic) / len(solved)
    stamp(results)
    return results, [spent + share for spent in seconds]


def _judged(solved):
    """The results of `solved`, each a (problem, IPOPT's result) or the result of an item
    that produced no solve: the converged optima judged together
    (`dmoc.drivers.verdict.verdicts`, then `judged`, ``throw=False``), the others as they
    are, as `optimize` returns each. Should the verdicts raise, each optimum is judged
    alone, so that an error stays its item's ("exception")."""
    results = [s if isinstance(s, OptimizationResult) else s[1] for s in solved]
    converged = [i for i, s in enumerate(solved) if not isinstance(s, OptimizationResult)
                 and s[1].success]
    try:
        found = verdicts([solved[i] for i in converged])
    except BaseException:       # any error of the group: each optimum again, alone
        found = [attempt(OptimizationResult, lambda pair=solved[i]: pair, lambda pair: judge(*pair))
                 for i in converged]
    for i, verdict in zip(converged, found):
        results[i] = verdict if isinstance(verdict, OptimizationResult) else \
            judged(results[i], verdict, throw=False)
    return results


def simulate_chunk(digest, items, timeout, keep="trajectory", share=None, budget=None):
    """For each item, ``shipping.pickled(run)``: ``simulate(disc, **run, throw=False)`` on
    the shipped Discretization, its trajectory cut to the last knot when `keep` is
    ``"final"`` (`final_knot`); as `optimize_chunk`, the results a `PackedResults` (their
    trajectories travel as one buffer, a slot of the client's shared memory when `share`,
    the client's `shared_memory.Exchange`, reaches this worker: the chunk's `ChunkMemory`).

    Without a `timeout`, the runs that can step together do so in lockstep
    (`dmoc.simulation.lockstep`: the same results as one by one, for less CPU), their
    trajectories written straight into the chunk's memory; each item's seconds are then
    the chunk's CPU seconds over its items. With a `timeout`, each item
    runs alone, in a thread the task can abandon. With a `budget`, the chunk ends once it
    has spent that many CPU seconds, as in `optimize_chunk` (in lockstep, groups of 1, 2,
    4, ... runs, `_in_budget`)."""
    def runner(item):
        def load():
            return shipped(digest, cloudpickle.loads), cloudpickle.loads(item)

        def solve(loaded):
            disc, run = loaded
            return simulate(disc, **run, throw=False)
        return load, solve

    calls, memory = [runner(item) for item in items], ChunkMemory(share)
    try:
        if timeout is None:
            results, seconds = _in_budget(calls, keep == "final", budget, memory.take)
        else:
            results, seconds = guarded_chunk(SimulationResult, calls, timeout, budget)
            if keep == "final":
                _cut_to_final_knots(results)
    except BaseException:           # the slot taken must not stay locked
        memory.file.release()
        raise
    return PackedResults(results, memory), seconds


def _in_budget(calls, final, budget, memory=np.empty):
    """(results, seconds) of the first of `calls` run in lockstep (`_in_lockstep`, the
    trajectories copied into ``memory(size)``): all of them when `budget` is None; else
    groups of 1, 2, 4, ... items, each at most what the CPU seconds left of the `budget`
    pay at the cost per item so far, until the budget is spent (so a chunk of slow items
    still returns within about its budget)."""
    if budget is None:
        return _in_lockstep(calls, final, memory)
    results, seconds, size = [], [], 1
    while len(results) < len(calls) and sum(seconds) < budget:
        group, spent = _in_lockstep(calls[len(results):len(results) + size], final, memory)
        results += group
        seconds += spent
        affordable = (budget - sum(seconds)) * len(results) / max(sum(seconds), 1e-9)
        size = max(1, min(2 * size, math.floor(affordable)))
    return results, seconds


def _in_lockstep(calls, final, memory):
    """(results, seconds) of the (load, solve) `calls` of `simulate_chunk`: each item's
    arguments loaded in its own guard, then checked together (`prepare_runs`: an item
    refused gets its own "exception" result) and the runs prepared stepped in lockstep
    (`simulate_lockstep`, their trajectories of the last knot only when `final`, copied
    into ``memory(size)``); should that raise, each item runs alone (`_alone`), so an
    error stays its item's. The runs of a GroupDiscretization (a rigid body on SO(3),
    which `simulate_lockstep` does not step) each run alone. Each result is stamped with this worker's address; the seconds are
    the chunk's CPU time shared equally."""
    tic = time.process_time()
    results = [attempt(SimulationResult, load, lambda pair: pair) for load, _ in calls]
    loaded = {i: pair for i, pair in enumerate(results) if not isinstance(pair, SimulationResult)}
    if any(isinstance(disc, GroupDiscretization) for disc, _ in loaded.values()):
        stepped = _alone(calls, loaded, final)      # no lockstep on SO(3): each run alone
    else:
        try:
            stepped = _lockstep(list(loaded.values()), final, memory)
        except BaseException:       # any error of the group: each item again, alone
            stepped = _alone(calls, loaded, final)
    for i, result in zip(loaded, stepped):
        results[i] = result
    stamp(results)
    return results, [(time.process_time() - tic) / len(calls)] * len(calls)


def _alone(calls, indices, final):
    """The SimulationResults of the `calls` of `indices`, each run alone (`guarded`) and,
    when `final`, cut to its last knot (`final_knot`)."""
    stepped = [guarded(SimulationResult, *calls[i], None)[0] for i in indices]
    if final:
        _cut_to_final_knots(stepped)
    return stepped


def _lockstep(loaded, final, memory):
    """The SimulationResults of the (disc, run) pairs `loaded`, all of one shipment (one
    Discretization): `prepare_runs`, then `simulate_lockstep` of the runs prepared (their
    trajectories copied into ``memory(size)``)."""
    if not loaded:
        return []
    prepared = prepare_runs(loaded[0][0], [dict(run, throw=False) for _, run in loaded])
    stepped = iter(simulate_lockstep([run for run in prepared if isinstance(run, Run)],
                                     final=final, memory=memory))
    return [next(stepped) if isinstance(run, Run) else
            caught(SimulationResult, Status.EXCEPTION, "", run) for run in prepared]


def _cut_to_final_knots(results):
    """Each of `results` that has a trajectory keeps only its last knot (`final_knot`)."""
    for result in results:
        if result.trajectory is not None:
            result.trajectory = final_knot(result.trajectory)


def final_knot(trajectory):
    """The last knot of `trajectory` as a Trajectory of no step (`Trajectory.assembled`
    with ``final``), or as a RotationTrajectory of no step; copies, so the run's arrays
    can go."""
    tr = trajectory
    if isinstance(tr, RotationTrajectory):
        return RotationTrajectory(tr.t[-1:], tr.R[-1:], tr.Pi[-1:], tr.f[:0], tr.u[:0], tr.h,
                                  x=tr.x[-1:], p_x=tr.p_x[-1:], lam=tr.lam[:0])
    return Trajectory.assembled(tr.t, tr.q, tr.p, tr.lam, tr.u, tr.h, tr.variant, tr.mu, tr.s,
                                tr.control_nodes, tr.stage_nodes, final=True)
