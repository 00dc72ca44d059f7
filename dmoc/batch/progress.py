"""The text bar a batch draws on stderr while its results arrive: items done, the time
elapsed, and the time still to go at the rate so far; redrawn in place on a terminal, one
plain line per tenth of the items in a log (a file, a pipe, a CI log)."""

import time


class ProgressBar:
    """A one-line text bar of completed items,
    ``optimize [#####.........................] 32/64 elapsed 0:05 eta 0:05``.

    The ETA is the elapsed time times (total - done) / done; ``eta ?`` before any item is
    done. On a terminal the bar is redrawn in place (``\\r``) at every item; elsewhere
    (a stream whose ``isatty()`` is False: a file, a pipe, a CI log) a ``\\r`` is no
    redraw, so the bar is written as a plain line at the first item done and each time the
    items done reach another tenth of the total (and at `close`, if the last line was not
    the final state): at most 11 lines, whatever the number of items.

    Parameters
    ----------
    total : int
    label : str
    stream : file or None
        Where to draw (None: draw nothing).
    clock : callable
        Seconds, monotonic (default `time.monotonic`).
    terminal : bool or None
        Redraw in place; None (default): when ``stream.isatty()`` says so.

    Examples
    --------
    >>> import io
    >>> ticks = iter([0.0, 10.0, 10.0])
    >>> stream = io.StringIO()
    >>> bar = ProgressBar(4, "optimize", stream, clock=lambda: next(ticks))
    >>> bar.advance(1)
    >>> stream.getvalue()
    'optimize [#######.......................] 1/4 elapsed 0:10 eta 0:30\\n'
    """

    WIDTH = 30

    def __init__(self, total, label, stream, clock=time.monotonic, terminal=None):
        self.total, self.label, self.stream, self.done = total, label, stream, 0
        self.clock = clock
        self.start = clock()
        if terminal is None:
            isatty = getattr(stream, "isatty", None)
            terminal = bool(isatty()) if callable(isatty) else False
        self.terminal, self._written = terminal, (-1, 0)    # (tenth, done) of the last line
        self._draw()

    def advance(self, count=1):
        """`count` more items are done."""
        self.done += count
        self._draw()

    def close(self):
        """End the bar: a newline on a terminal; elsewhere the final state's line, unless
        it is the last line written."""
        if self.stream is None:
            return
        if self.terminal:
            self.stream.write("\n")
        elif self._written != (self._tenth(), self.done):
            self._write_line()
        self.stream.flush()

    def _tenth(self):
        """The tenths of the total done, rounded down (10 when all are); -1 before any."""
        return 10 * self.done // max(self.total, 1) if self.done else -1

    def _draw(self):
        if self.stream is None:
            return
        if self.terminal:
            self.stream.write("\r" + self._line())
        elif self._tenth() > self._written[0]:
            self._write_line()
        self.stream.flush()

    def _write_line(self):
        self.stream.write(self._line() + "\n")
        self._written = (self._tenth(), self.done)

    def _line(self):
        """The bar's text now."""
        elapsed = self.clock() - self.start
        eta = clock_time(elapsed * (self.total - self.done) / self.done) if self.done else "?"
        filled = self.WIDTH * self.done // max(self.total, 1)
        return (f"{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] "
                f"{self.done}/{self.total} elapsed {clock_time(elapsed)} eta {eta}")


def clock_time(seconds):
    """`seconds` as ``m:ss``, or ``h:mm:ss`` from one hour on.

    >>> clock_time(5.4), clock_time(75), clock_time(3725)
    ('0:05', '1:15', '1:02:05')
    """
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
