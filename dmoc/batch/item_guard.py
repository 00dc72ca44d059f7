"""Every item of a batch gets a result of its own, on the worker (the batch stage of both
consumers of the step residual): an item's load and solve run inside a guard that turns
whatever they raise, `SystemExit` and `KeyboardInterrupt` included, into that item's
failed result ("undeserializable" when its arguments do not unpickle, "exception"
otherwise), and, with a per-item timeout, in a thread of its own that the chunk abandons
when the time is up ("timeout"); a chunk of items runs them in turn within its CPU budget,
each result stamped with the worker's address.
"""

import threading
import time
import traceback

import distributed

from ..errors import Status
from ..optimal_control.solver.optimization_result import OptimizationResult
from ..simulation.time_stepping import SimulationResult


def failed_result(kind, status, message, **stats):
    """A result of `kind` for an item that produced none: no trajectory, success False."""
    if kind is OptimizationResult:
        return OptimizationResult(None, float("nan"), False, status, message, stats, None)
    return SimulationResult(None, False, status, message, stats)


def guarded_chunk(kind, calls, timeout, budget):
    """`in_turn`, each result stamped with this worker's address."""
    results, seconds = in_turn(kind, calls, timeout, budget)
    stamp(results)
    return results, seconds


def in_turn(kind, calls, timeout, budget):
    """(results, seconds) of each (load, solve) of `calls` in turn (`guarded`), up to and
    including the first that times out or that spends the `budget` (CPU seconds of the
    chunk; None: no limit). The seconds are this process's CPU time over the item, which
    other jobs on the machine do not inflate as they do the wall time."""
    results, seconds = [], []
    for load, solve in calls:
        tic = time.process_time()
        result, finished = guarded(kind, load, solve, timeout)
        seconds.append(time.process_time() - tic)
        results.append(result)
        if not finished or (budget is not None and sum(seconds) >= budget):
            break
    return results, seconds


def stamp(results):
    """Each result's ``stats["worker"]``: the address of this worker."""
    worker = distributed.get_worker().address
    for result in results:
        result.stats["worker"] = worker


def guarded(kind, load, solve, timeout):
    """(solve(load()) as a result of `kind`, whether it finished): an error in `load`
    gives status "undeserializable", one in `solve` "exception", and a run longer than
    `timeout` seconds (None: no limit) "timeout"."""
    if timeout is None:
        return attempt(kind, load, solve), True
    box = []
    thread = threading.Thread(target=lambda: box.append(attempt(kind, load, solve)),
                              name="dmoc-batch-item", daemon=True)
    thread.start()
    thread.join(timeout)
    if box:
        return box[0], True
    return failed_result(kind, Status.TIMEOUT, f"the item ran longer than `timeout`={timeout:g} s "
                         "and was abandoned; its worker is restarted (if it has a nanny) "
                         "to stop it"), False


def attempt(kind, load, solve):
    """solve(load()), or the failed result of `kind` for what `load` ("undeserializable")
    or `solve` ("exception") raised."""
    try:
        loaded = load()
    except BaseException as err:  # an argument this worker cannot load is the item's result
        return caught(kind, Status.UNDESERIALIZABLE, "its arguments could not be unpickled on "
                       "the worker (is every class they use importable there?)", err)
    try:
        return solve(loaded)
    except BaseException as err:  # SystemExit too: one item must not end the worker
        return caught(kind, Status.EXCEPTION, "", err)


def caught(kind, status, context, err):
    """The failed result of `kind` with `status` for the error `err`: its type and message
    after `context`, its traceback in the stats."""
    message = f"{type(err).__name__}: {err}"
    return failed_result(kind, status, f"{context}: {message}" if context else message,
                         traceback="".join(traceback.format_exception(err)))
