"""The errors of a batch that cannot run, or is interrupted, as a whole (docs/batch.md,
"Failure semantics"): a scheduler that cannot be reached, worker processes that cannot
start, and Ctrl-C while the client waits. A failure of one item is never raised: it is
that item's result."""

from ..errors import DmocError, Status


class SchedulerUnreachable(DmocError, OSError):
    """The scheduler address given as `client` did not answer within `connect_timeout`; the
    message names the address. Also an `OSError`, as distributed's own connection error."""


class WorkersFailedToStart(DmocError, RuntimeError):
    """The LocalCluster's worker processes did not start, or an `optimize_many` /
    `simulate_many` call ran while a spawned worker process re-imported the user's script
    (a script without ``if __name__ == "__main__":``); the message names the fix."""


class BatchInterrupted(KeyboardInterrupt):
    """Ctrl-C (KeyboardInterrupt) while the client waited for a batch.

    It is a KeyboardInterrupt and not a `DmocError` (an `Exception`), so that an
    ``except Exception`` around the call does not swallow the interrupt.

    Parameters
    ----------
    results : list of OptimizationResult or SimulationResult, length B
        In input order: every result that had arrived, and for each item still running or
        queued a failed result with ``status="interrupted"``.
    """

    def __init__(self, results):
        done = sum(r.status != Status.INTERRUPTED for r in results)
        super().__init__(f"batch interrupted: {done} of {len(results)} results had arrived; "
                         "they are in `.results`, the others have status 'interrupted'.")
        self.results = results
