"""The client side of a batch: ship each structure once (`tasks.Shipment`), submit the
items in chunks sized from their measured cost, and collect one result per item in input
order, whatever happens to the items, the workers or the client (docs/batch.md, "Failure
semantics").

At most `CHUNKS_PER_THREAD` chunks per worker thread are in flight, so that the next
chunk's size uses the costs measured so far; until a cost is measured, the chunks carry a
CPU budget after which their workers return them with the items run so far
(`ChunkSizes.budget`), so no worker waits for the client to size its work and a chunk of
slow items ends within its budget. The client waits in ticks of `TICK` seconds, so that
the batch's deadline, a cluster left without workers and Ctrl-C are noticed while nothing
arrives; a lost scheduler (Dask cancels the client's futures) ends the wait at once, with
the results that arrived.
"""

import sys
import time
import uuid
from collections import deque

import distributed
from distributed.client import FutureCancelledError, FuturesCancelledError

from ..errors import Status
from .chunk_sizes import ChunkSizes
from .cluster import client_of, close
from .failures import BatchInterrupted
from .item_guard import failed_result
from .progress import ProgressBar
from .tasks import Shipment

# Re-runs of a task whose worker *returned* an error outside dmoc's task function (e.g. the
# function itself failed to deserialize there). A task whose worker dies is rescheduled by
# the scheduler instead, up to `distributed.scheduler.allowed-failures` times (default 3).
RETRIES = 2

TICK = 0.5

CHUNKS_PER_THREAD = 2

LOST = ("the connection to the scheduler was lost (it stopped, or the network failed) "
        "before this item's result arrived")

# Seconds a worker restarted to stop an abandoned item gets to shut down before it is
# removed from the scheduler.
RESTART_TIMEOUT = 10


def run(task, arguments, shipments, items, kind, client, *, label, progress, batch_timeout,
        connect_timeout):
    """``task(digest, [bytes, ...], *arguments)`` on chunks of `items` ((digest, data)
    each, the bytes of data, ``bytes(data)``, made as its chunk is submitted:
    `shipping.item`) after shipping `shipments` ({digest: bytes}); the results of `kind`
    in input order (`Batch.collect`)."""
    try:
        client, owned = client_of(client, connect_timeout)
    except KeyboardInterrupt:
        raise BatchInterrupted([failed_result(kind, Status.INTERRUPTED, "Ctrl-C while the cluster "
                                              "(`client`) was starting") for _ in items]) from None
    names = []
    try:
        ship(client, shipments, names)
        bar = ProgressBar(len(items), label, sys.stderr if progress else None)
        try:
            batch = Batch(client, task, arguments, items, kind, label)
            return batch.collect(bar, batch_timeout=batch_timeout, connect_timeout=connect_timeout)
        finally:
            bar.close()
    finally:
        unship(client, names)
        if owned:
            close(client)


def ship(client, shipments, names):
    """Register one `Shipment` per entry of `shipments` on every worker, appending the
    name of each to `names`."""
    for digest, data in shipments.items():
        names.append(f"dmoc-shipment-{digest}-{uuid.uuid4().hex[:8]}")
        client.register_plugin(Shipment(digest, data), name=names[-1])


def unship(client, names):
    """Unregister the Shipments `names` (the workers drop their bytes), unless the
    scheduler is gone: then nothing holds them any more."""
    if client.status != "running":
        return
    for name in names:
        try:
            client.unregister_worker_plugin(name)
        except OSError:     # the connection is lost; the batch's own outcome stands
            return


class Batch:
    """The items of one call: queued (input order), in flight (chunks), or with a result."""

    def __init__(self, client, task, arguments, items, kind, label):
        self.client, self.task, self.arguments, self.items, self.kind = client, task, arguments, items, kind
        self.key = f"dmoc-{label}-{uuid.uuid4().hex[:8]}"
        self.results, self.queued, self.flying = [None] * len(items), deque(range(len(items))), {}
        self.alone, self.sizes, self.submitted = set(), ChunkSizes(), 0
        self.threads, self.asked = 0, -float("inf")

    def collect(self, bar, *, batch_timeout, connect_timeout):
        """One result per item, in order: a returned result as it is, a chunk the scheduler
        gave up on as failed results (`_land`); at the batch's deadline the unfinished
        items become "timeout" results, after `connect_timeout` seconds without any worker
        "worker_lost" ones; Ctrl-C raises BatchInterrupted with the results so far. The
        worker of an item past its own `timeout` is restarted, to stop the abandoned
        computation."""
        deadline = None if batch_timeout is None else time.monotonic() + batch_timeout
        workerless = None
        try:
            while (self.queued or self.flying) and not self._scheduler_lost():
                threads = self._threads()
                self._fill(max(threads, 1))
                try:
                    distributed.wait(list(self.flying), timeout=TICK, return_when="FIRST_COMPLETED")
                except (TimeoutError, FuturesCancelledError):
                    pass
                if self._scheduler_lost():
                    break
                bar.advance(sum(self._land(f) for f in [f for f in self.flying if f.done()]))
                now = time.monotonic()
                if deadline is not None and now >= deadline:
                    self._abandon(Status.TIMEOUT, f"the batch ran longer than `batch_timeout`="
                                  f"{batch_timeout:g} s before this item finished")
                workerless = None if threads else (workerless or now)
                if workerless is not None and now - workerless >= connect_timeout:
                    self._abandon(Status.WORKER_LOST, f"the scheduler had no worker for "
                                  f"{connect_timeout:g} s (`connect_timeout`)")
        except KeyboardInterrupt:
            for future in [f for f in self.flying if f.status == "finished"]:
                self._land(future)
            self._abandon(Status.INTERRUPTED, "Ctrl-C (KeyboardInterrupt) before this item finished")
            raise BatchInterrupted(self.results) from None
        return self.results

    def _scheduler_lost(self):
        """Whether the client lost its scheduler (Dask then cancels every future of the
        client; the batch cancels its own only in `_abandon`, which forgets them); if so,
        every unfinished item gets a "scheduler_lost" result."""
        if self.client.status == "running" and not any(f.cancelled() for f in self.flying):
            return False
        self._abandon(Status.SCHEDULER_LOST, LOST, cancel=False)
        return True

    def _threads(self):
        """The cluster's worker threads, asked of the scheduler at most once per TICK."""
        now = time.monotonic()
        if now - self.asked >= TICK:
            try:
                self.threads, self.asked = sum(self.client.nthreads().values()), now
            except OSError:         # the connection is lost: `_scheduler_lost` tells the batch
                pass
        return self.threads

    def _fill(self, threads):
        """Submit chunks of queued items while fewer than CHUNKS_PER_THREAD per worker
        thread are in flight: consecutive items of one shipment, as many as
        `ChunkSizes.next` says for the queue before the first of them (so the chunks of
        the first call, one or two per worker thread, are equal and the workers' first
        rounds end together), with its `budget`, all in one message to the scheduler
        (`distributed.Client.map`: the client batches the messages it sends within 10 ms
        of each other, so chunks submitted one by one reach the second worker 10 ms after
        the first). An item whose chunk lost its workers goes alone, and while such items
        are left only one task is in flight, so that a worker's death fails that task
        alone. `threads`: the cluster's worker threads."""
        limit = 1 if self.alone else CHUNKS_PER_THREAD * threads
        chunks, share = [], self.sizes.next(len(self.queued), threads)
        while self.queued and len(self.flying) + len(chunks) < limit:
            first = self.queued.popleft()
            digest, chunk = self.items[first][0], [first]
            size = 1 if first in self.alone else share
            while (len(chunk) < size and self.queued and self.queued[0] not in self.alone
                   and self.items[self.queued[0]][0] == digest):
                chunk.append(self.queued.popleft())
            chunks.append(chunk)
        if not chunks:
            return
        keys = [f"{self.key}-{self.submitted + k}" for k in range(len(chunks))]
        futures = self.client.map(
            self.task, [self.items[chunk[0]][0] for chunk in chunks],
            [[bytes(self.items[i][1]) for i in chunk] for chunk in chunks],
            *([argument] * len(chunks) for argument in self.arguments),
            budget=self.sizes.budget, key=keys, pure=False, retries=RETRIES)
        self.flying.update(zip(futures, chunks))
        self.submitted += len(chunks)

    def _land(self, future):
        """Take the results of a finished chunk; the number of items that got one. Items a
        timeout or the chunk's budget left unrun are queued again; the items of a chunk
        whose workers kept dying are queued again one per chunk, so only the culprit ends
        "worker_lost"."""
        chunk = self.flying.pop(future)
        try:
            results, seconds = future.result()
        except FutureCancelledError:     # the connection to the scheduler was lost meanwhile
            results, seconds = [failed_result(self.kind, Status.SCHEDULER_LOST, LOST) for _ in chunk], []
        except distributed.KilledWorker as err:
            results, seconds = [failed_result(self.kind, Status.WORKER_LOST, f"KilledWorker: {err}")], []
            if len(chunk) > 1:
                self.alone.update(chunk)
                results = []
        except Exception as err:  # raised outside dmoc's task: the items' own results
            results, seconds = [failed_result(
                self.kind, Status.EXCEPTION, "the task failed outside dmoc's call (e.g. it could "
                f"not be deserialized): {type(err).__name__}: {err}") for _ in chunk], []
        future.release()
        for i, result in zip(chunk, results):
            self.results[i] = result
        self.alone.difference_update(chunk[:len(results)])
        self.queued.extendleft(reversed(chunk[len(results):]))
        self.sizes.measured(seconds)
        if results and results[-1].status == Status.TIMEOUT:
            restart(self.client, {results[-1].stats["worker"]})
        return len(results)

    def _abandon(self, status, message, cancel=True):
        """Give each unfinished item a failed result of `status` and, with `cancel`, cancel
        the chunks in flight (a chunk a worker is already running runs on to its end
        there)."""
        for i in [*self.queued, *(i for chunk in self.flying.values() for i in chunk)]:
            self.results[i] = failed_result(self.kind, status, message)
        if cancel:
            self.client.cancel(list(self.flying))
        self.queued.clear()
        self.flying.clear()


def restart(client, workers):
    """Restart `workers` through their nannies (a worker without one could not come back),
    without waiting for the new processes to join: the batch goes on with the others."""
    info = client.scheduler_info(n_workers=-1)["workers"]
    workers = [w for w in workers if info.get(w, {}).get("nanny")]
    if workers:
        client.sync(client.scheduler.restart_workers, workers=workers, timeout=RESTART_TIMEOUT,
                    wait_for_workers=False, on_error="return",
                    stimulus_id=f"dmoc-batch-restart-{time.time()}")
