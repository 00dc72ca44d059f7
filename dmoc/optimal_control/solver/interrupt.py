"""Ctrl-C during an IPOPT solve (consumer 2, its solver half). CasADi checks Python's
signals in IPOPT's callbacks; a SIGINT there makes Python's handler raise KeyboardInterrupt
inside the check, CasADi turns it into a C++ exception, IPOPT stops with
``NonIpopt_Exception_Thrown`` and the solver returns its last iterate with the interrupt
swallowed (CasADi 3.8, the version tested). That status alone cannot tell a Ctrl-C from
an exception of another callback, so `watch` notes every SIGINT that arrives during the
solve.
"""

import _signal       # the C module under `signal`, without its wrappers' enum conversions
import signal
import threading

from ...errors import Status

__all__ = ["watch", "verdict"]


class watch:
    """A context manager: ``with watch() as seen`` gives a list that gets an entry for each
    SIGINT Python handles inside the block; the handler in place before is still called
    (by default it raises KeyboardInterrupt). Outside the main thread (where Python
    handles no signal) or when SIGINT is ignored or left to the system, the list stays
    empty and nothing is installed. The handlers are read and set through `_signal`, the
    C module whose functions `signal` wraps: the wrappers' conversions of handlers to
    enums (a ValueError caught for every callable) were most of the block's cost per
    solve; only a handler that is no callable would convert, and none is installed then.
    A class, not a generator, whose context manager costs more per re-solve
    (benchmarks/peers.py resolve)."""

    __slots__ = ("seen", "_previous")

    def __enter__(self):
        self.seen, self._previous = [], _signal.getsignal(signal.SIGINT)
        if threading.current_thread() is not threading.main_thread() or not callable(self._previous):
            self._previous = None
            return self.seen
        seen, previous = self.seen, self._previous

        def noted(signum, frame):
            seen.append(signum)
            previous(signum, frame)

        _signal.signal(signal.SIGINT, noted)
        return seen

    def __exit__(self, *exception):
        if self._previous is not None:
            _signal.signal(signal.SIGINT, self._previous)
        return False


def verdict(seen, iterations, cost):
    """(status, message) of a solve during which the SIGINTs `seen` arrived, or None when
    there was none: status ``"interrupted"``, the message saying so and where IPOPT stood."""
    if not seen:
        return None
    return Status.INTERRUPTED, (f"IPOPT: interrupted (KeyboardInterrupt) after {iterations} "
                           f"iterations, cost {cost:.10g} at the last iterate.")
