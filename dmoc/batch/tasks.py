"""The worker side of a batch: one task per item runs `optimize` or `simulate` (the two
consumers of the step residual) on arguments shipped as bytes, and always returns a
result of its own, whatever the item does.

Each task unpickles its own arguments, so an argument the worker cannot load (a class
only the client can import) is that item's ``"undeserializable"`` result and not an error
of the worker. Everything an item raises, `SystemExit` and `KeyboardInterrupt` included,
is caught, so one item cannot end the worker process that runs its neighbours. With a
per-item timeout the item runs in a thread of its own, which the task abandons when the
time is up.
"""

import threading
import traceback

import casadi as ca
import cloudpickle
import distributed

from ..optimize.solve import OptimizationResult
from ..results.optimum import optimize
from ..simulate.simulation import SimulationResult, simulate


def pack_problem(problem):
    """An OptimalControlProblem as bytes, its CasADi graphs in a pickle context."""
    with ca.global_pickle_context():
        return cloudpickle.dumps(problem)


def unpack_problem(data):
    """The OptimalControlProblem written by `pack_problem`."""
    with ca.global_unpickle_context():
        return cloudpickle.loads(data)


def optimize_task(problem, guess, options, switches, timeout):
    """`optimize(problem, guess=guess, options=options, **switches, throw=False)` on the
    bytes of `pack_problem` and of ``cloudpickle.dumps(guess)``; never raises."""
    def load():
        return unpack_problem(problem), cloudpickle.loads(guess)

    def solve(loaded):
        return optimize(loaded[0], guess=loaded[1], options=options, **switches, throw=False)

    return _guarded(OptimizationResult, load, solve, timeout)


def simulate_task(data, timeout):
    """`simulate(disc, **run, throw=False)` on the bytes of ``cloudpickle.dumps((disc,
    run))``; never raises."""
    def solve(loaded):
        disc, run = loaded
        return simulate(disc, **run, throw=False)

    return _guarded(SimulationResult, lambda: cloudpickle.loads(data), solve, timeout)


def failed_result(kind, status, message, **stats):
    """A result of `kind` for an item that produced none: no trajectory, success False."""
    if kind is OptimizationResult:
        return OptimizationResult(None, float("nan"), False, status, message, stats, None)
    return SimulationResult(None, False, status, message, stats)


def _guarded(kind, load, solve, timeout):
    """solve(load()) as a result of `kind` stamped with this worker's address: an error
    in `load` gives status "undeserializable", one in `solve` "exception", and a run
    longer than `timeout` seconds (None: no limit) "timeout"."""
    if timeout is None:
        result = _attempt(kind, load, solve)
    else:
        box = []
        thread = threading.Thread(target=lambda: box.append(_attempt(kind, load, solve)),
                                  name="dmoc-batch-item", daemon=True)
        thread.start()
        thread.join(timeout)
        result = box[0] if box else failed_result(
            kind, "timeout", f"the item ran longer than `timeout`={timeout:g} s and was "
            "abandoned; its worker is restarted (if it has a nanny) to stop it")
    result.stats["worker"] = distributed.get_worker().address
    return result


def _attempt(kind, load, solve):
    try:
        loaded = load()
    except BaseException as err:  # an argument this worker cannot load is the item's result
        return _caught(kind, "undeserializable", "its arguments could not be unpickled on "
                       "the worker (is every class they use importable there?)", err)
    try:
        return solve(loaded)
    except BaseException as err:  # SystemExit too: one item must not end the worker
        return _caught(kind, "exception", "", err)


def _caught(kind, status, context, err):
    message = f"{type(err).__name__}: {err}"
    return failed_result(kind, status, f"{context}: {message}" if context else message,
                         traceback=traceback.format_exc())
