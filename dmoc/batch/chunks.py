"""How many items one task of a batch carries: enough that a task takes about `TARGET`
seconds of its worker's CPU, so that Dask's cost per task (about 5 ms of CPU on the
2-vCPU machine of docs/performance.md: scheduling, round trips, pickling, in the client,
the scheduler and the worker) is small next to the solves, and few enough that every
worker thread still gets a couple of tasks before the batch ends."""

import math
from collections import deque
from statistics import median

# CPU seconds of work one task aims at: a few hundred milliseconds (docs/batch.md).
TARGET = 0.2

# The chunks each worker thread gets at least from the items still queued, so that the
# last tasks end close together ...
SHARES = 2

# ... but no chunk carries less than FLOOR CPU seconds (unless fewer items are left): a
# task costs Dask about 5 ms of CPU, which a chunk of 0.05 s keeps under a tenth
# (docs/performance.md, "Fourth round").
FLOOR = 0.05

# The per-item costs the median is taken over: the latest ones, so a first solve that
# built its solver is soon outweighed.
WINDOW = 64


class ChunkSizes:
    """The size of the next chunk from the CPU seconds the items took on their workers.

    Until a cost is measured every chunk holds one item; then
    ``min(TARGET / cost, max(queued / (SHARES * threads), FLOOR / cost))`` for the median
    cost of an item, at least one.

    >>> sizes = ChunkSizes()
    >>> sizes.known, sizes.next(1000, 2)
    (False, 1)
    >>> sizes.measured([0.004, 0.005, 0.006])
    >>> sizes.next(1000, 2), sizes.next(40, 2), sizes.next(8, 2)
    (40, 10, 10)
    """

    def __init__(self):
        self._seconds = deque(maxlen=WINDOW)

    def measured(self, seconds):
        """Record the CPU seconds each item of a finished chunk took on its worker."""
        self._seconds.extend(seconds)

    @property
    def known(self):
        """Whether a cost has been measured."""
        return bool(self._seconds)

    def next(self, queued, threads):
        """The size of the next chunk, with `queued` items left and `threads` worker
        threads."""
        if not self._seconds:
            return 1
        cost = max(median(self._seconds), 1e-6)
        balanced = max(math.ceil(queued / (SHARES * threads)), math.ceil(FLOOR / cost))
        return max(1, min(int(TARGET / cost), balanced))
