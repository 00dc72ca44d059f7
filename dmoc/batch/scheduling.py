"""The client side of a batch: connect to a scheduler (or start a LocalCluster), submit one
task per item, and collect one result per item in input order, whatever happens to the
items, the workers or the client (docs/batch.md, "Failure semantics").

The client waits in ticks of `TICK` seconds, so that the batch's deadline, a cluster left
without workers and Ctrl-C are noticed while nothing arrives.
"""

import os
import sys
import time
import uuid

import distributed

from ..errors import InputTypeError
from .errors import BatchInterrupted, SchedulerUnreachable, WorkersFailedToStart
from .progress import ProgressBar
from .tasks import failed_result

# Re-runs of a task whose worker *returned* an error outside dmoc's task function (e.g. the
# function itself failed to deserialize there). A task whose worker dies is rescheduled by
# the scheduler instead, up to `distributed.scheduler.allowed-failures` times (default 3).
RETRIES = 2

TICK = 0.5

# Seconds a worker restarted to stop an abandoned item gets to shut down before it is
# removed from the scheduler.
RESTART_TIMEOUT = 10


def run(task, arguments, kind, client, *, label, progress, batch_timeout, connect_timeout):
    """task(*args) for each entry of `arguments` as one Dask task each; the results of
    `kind` in input order (`_collect`)."""
    refuse_spawn_reimport()
    client, owned = connect(client, connect_timeout)
    try:
        batch = uuid.uuid4().hex[:8]
        futures = [client.submit(task, *args, key=f"dmoc-{label}-{batch}-{i}", pure=False,
                                 retries=RETRIES) for i, args in enumerate(arguments)]
        bar = ProgressBar(len(futures), label, sys.stderr if progress else None)
        try:
            return _collect(client, futures, kind, bar, batch_timeout=batch_timeout,
                            connect_timeout=connect_timeout)
        finally:
            bar.close()
    finally:
        if owned:
            close(client)


def refuse_spawn_reimport():
    """Raise WorkersFailedToStart when called at the top level of a script that a spawned
    process is re-importing (as ``__mp_main__``): the script lacks its main guard, and
    without this check every worker process would start a cluster of its own."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "<module>" and frame.f_globals.get("__name__") == "__mp_main__":
            raise WorkersFailedToStart(
                "dmoc.batch was called while a worker process re-imported the script "
                f"{frame.f_globals.get('__file__')!r}: worker processes are spawned and "
                "import the main script again. Put the batch under "
                "`if __name__ == \"__main__\":`.")
        frame = frame.f_back


def connect(client, connect_timeout):
    """(Client, whether this call owns it and must close it)."""
    if client is None:
        try:
            cluster = distributed.LocalCluster(n_workers=os.cpu_count() or 1,
                                               threads_per_worker=1, processes=True,
                                               dashboard_address=":0")
        except Exception as err:
            script = getattr(sys.modules.get("__main__"), "__file__", None)
            hint = (f" If {script!r} runs the batch at its top level, put the call under "
                    "`if __name__ == \"__main__\":` (worker processes are spawned and "
                    "import the main script again)." if script else "")
            raise WorkersFailedToStart(f"the LocalCluster's worker processes failed to "
                                       f"start ({type(err).__name__}: {err}).{hint}") from err
        return distributed.Client(cluster), True
    if isinstance(client, str):
        try:
            return distributed.Client(client, timeout=connect_timeout), True
        except (OSError, TimeoutError) as err:
            raise SchedulerUnreachable(
                f"could not reach a Dask scheduler at `client`={client!r} within "
                f"`connect_timeout`={connect_timeout:g} s ({type(err).__name__}: {err}). "
                "Check the address and that `dask scheduler` runs there.") from err
    if isinstance(client, distributed.Client):
        return client, False
    raise InputTypeError("`client` must be None (a LocalCluster on this machine), a "
                         "distributed.Client or a scheduler address such as 'tcp://host:8786'; "
                         f"got {type(client).__name__}.")


def close(client):
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()


def _collect(client, futures, kind, bar, *, batch_timeout, connect_timeout):
    """One result per future, in order: a returned result as it is, a future the scheduler
    gave up on as a failed result (`_gather`); at the batch's deadline the unfinished ones
    become "timeout" results, after `connect_timeout` seconds without any worker
    "worker_lost" ones; Ctrl-C raises BatchInterrupted with the results so far. The worker
    of an item past its own `timeout` is restarted, to stop the abandoned computation."""
    results, pending = [None] * len(futures), dict(enumerate(futures))
    deadline = None if batch_timeout is None else time.monotonic() + batch_timeout
    workerless = None
    try:
        while pending:
            try:
                distributed.wait(list(pending.values()), timeout=TICK,
                                 return_when="FIRST_COMPLETED")
            except TimeoutError:
                pass
            for i in [i for i, future in pending.items() if future.done()]:
                results[i] = _gather(pending.pop(i), kind)
                bar.advance()
                if results[i].status == "timeout":      # stop the abandoned thread
                    _restart(client, {results[i].stats["worker"]})
            now = time.monotonic()
            if pending and deadline is not None and now >= deadline:
                _abandon(client, pending, results, kind, "timeout",
                         f"the batch ran longer than `batch_timeout`={batch_timeout:g} s "
                         "before this item finished")
            workerless = None if client.nthreads() else (workerless or now)
            if pending and workerless is not None and now - workerless >= connect_timeout:
                _abandon(client, pending, results, kind, "worker_lost",
                         f"the scheduler had no worker for {connect_timeout:g} s "
                         "(`connect_timeout`)")
    except KeyboardInterrupt:
        for i in [i for i, future in pending.items() if future.status == "finished"]:
            results[i] = _gather(pending.pop(i), kind)
        _abandon(client, pending, results, kind, "interrupted",
                 "Ctrl-C (KeyboardInterrupt) before this item finished")
        raise BatchInterrupted(results) from None
    return results


def _gather(future, kind):
    """The future's result, or a failed one when the scheduler gave up on it."""
    try:
        result = future.result()
    except distributed.KilledWorker as err:
        result = failed_result(kind, "worker_lost", f"KilledWorker: {err}")
    except Exception as err:  # raised outside dmoc's task: the item's own result
        result = failed_result(kind, "exception", "the task failed outside dmoc's call "
                               f"(e.g. it could not be deserialized): {type(err).__name__}: {err}")
    future.release()
    return result


def _abandon(client, pending, results, kind, status, message):
    """Give each pending item a failed result of `status` and cancel its task (a task a
    worker is already running runs on to its end there)."""
    for i in pending:
        results[i] = failed_result(kind, status, message)
    client.cancel(list(pending.values()))
    pending.clear()


def _restart(client, workers):
    """Restart `workers` through their nannies (a worker without one could not come back),
    without waiting for the new processes to join: the batch goes on with the others."""
    info = client.scheduler_info(n_workers=-1)["workers"]
    workers = [w for w in workers if info.get(w, {}).get("nanny")]
    if workers:
        client.sync(client.scheduler.restart_workers, workers=workers, timeout=RESTART_TIMEOUT,
                    wait_for_workers=False, on_error="return",
                    stimulus_id=f"dmoc-batch-restart-{time.time()}")
