"""The text bar a batch draws on stderr while its results arrive: items done, the time
elapsed, and the time still to go at the rate so far."""

import time


class ProgressBar:
    """A one-line text bar of completed items,
    ``optimize [#####.........................] 32/64 elapsed 0:05 eta 0:05``.

    The ETA is the elapsed time times (total - done) / done; ``eta ?`` before any item is
    done.

    Parameters
    ----------
    total : int
    label : str
    stream : file or None
        Where to draw (None: draw nothing).
    clock : callable
        Seconds, monotonic (default `time.monotonic`).

    Examples
    --------
    >>> import io
    >>> ticks = iter([0.0, 10.0, 10.0])
    >>> stream = io.StringIO()
    >>> bar = ProgressBar(4, "optimize", stream, clock=lambda: next(ticks))
    >>> bar.advance(1)
    >>> stream.getvalue().split("\\r")[-1]
    'optimize [#######.......................] 1/4 elapsed 0:10 eta 0:30'
    """

    WIDTH = 30

    def __init__(self, total, label, stream, clock=time.monotonic):
        self.total, self.label, self.stream, self.done = total, label, stream, 0
        self.clock = clock
        self.start = clock()
        self._draw()

    def advance(self, count=1):
        """`count` more items are done."""
        self.done += count
        self._draw()

    def close(self):
        if self.stream is not None:
            self.stream.write("\n")
            self.stream.flush()

    def _draw(self):
        if self.stream is None:
            return
        elapsed = self.clock() - self.start
        eta = clock_time(elapsed * (self.total - self.done) / self.done) if self.done else "?"
        filled = self.WIDTH * self.done // max(self.total, 1)
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] "
                          f"{self.done}/{self.total} elapsed {clock_time(elapsed)} eta {eta}")
        self.stream.flush()


def clock_time(seconds):
    """`seconds` as ``m:ss``, or ``h:mm:ss`` from one hour on.

    >>> clock_time(5.4), clock_time(75), clock_time(3725)
    ('0:05', '1:15', '1:02:05')
    """
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
