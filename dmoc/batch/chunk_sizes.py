"""How many items one task of a batch carries: enough that a task takes about `TARGET`
seconds of its worker's CPU, so that Dask's cost per task (about 5 ms of CPU on the
2-vCPU machine of benchmarks/batch.py: scheduling, round trips, pickling, in the client,
the scheduler and the worker) is small next to the solves, and few enough that every
worker thread still gets a couple of tasks before the batch ends."""

import math
from collections import deque
from statistics import median

# CPU seconds of work one task aims at: half a second, so that the client's share of Dask's
# cost per task stays a few per cent of a batch's CPU.
TARGET = 0.5

# The chunks each worker thread gets at least from the items still queued, so that the
# last tasks end close together ...
SHARES = 2

# ... but no chunk carries less than FLOOR CPU seconds (unless fewer items are left): a
# task costs Dask about 5 ms of CPU, which a chunk of 0.05 s keeps under a tenth.
FLOOR = 0.05

# The most items of a chunk sized before a cost is measured: those its worker does not
# reach within its budget travel for nothing, and a guess can be kilobytes.
FIRST = 256

# The per-item costs the median is taken over: the latest ones, so a first solve that
# built its solver is soon outweighed.
WINDOW = 64


class ChunkSizes:
    """The size of the next chunk from the CPU seconds the items took on their workers.

    Until a cost is measured a chunk holds its thread's share of the queue,
    ``queued / (SHARES * threads)`` (at most FIRST items), and its worker returns it after
    `budget` = TARGET CPU seconds with the items it ran (`tasks.simulate_chunk`); then
    ``min(TARGET / cost, max(queued / (SHARES * threads), FLOOR / cost))`` for the median
    cost of an item, at least one, with no budget.

    >>> sizes = ChunkSizes()
    >>> sizes.next(1000, 2), sizes.budget
    (250, 0.5)
    >>> sizes.measured([0.004, 0.005, 0.006])
    >>> sizes.next(1000, 2), sizes.next(40, 2), sizes.next(8, 2), sizes.budget
    (100, 10, 10, None)
    """

    def __init__(self):
        self._seconds = deque(maxlen=WINDOW)

    def measured(self, seconds):
        """Record the CPU seconds each item of a finished chunk took on its worker."""
        self._seconds.extend(seconds)

    @property
    def budget(self):
        """The CPU seconds after which a worker returns the next chunk with the results of
        the items it ran so far (the client queues the others again): `TARGET` until a
        cost is measured, None after."""
        return None if self._seconds else TARGET

    def next(self, queued, threads):
        """The size of the next chunk, with `queued` items left and `threads` worker
        threads."""
        share = math.ceil(queued / (SHARES * threads))
        if not self._seconds:
            return min(share, FIRST)
        cost = max(median(self._seconds), 1e-6)
        balanced = max(share, math.ceil(FLOOR / cost))
        return max(1, min(int(TARGET / cost), balanced))
