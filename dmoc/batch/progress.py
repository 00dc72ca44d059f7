"""The text bar a batch draws on stderr while its results arrive."""


class ProgressBar:
    """A one-line text bar of completed tasks, ``optimize [#####.....] 32/64``.

    Parameters
    ----------
    total : int
    label : str
    stream : file or None
        Where to draw (None: draw nothing).
    """

    WIDTH = 30

    def __init__(self, total, label, stream):
        self.total, self.label, self.stream, self.done = total, label, stream, 0
        self._draw()

    def advance(self):
        self.done += 1
        self._draw()

    def close(self):
        if self.stream is not None:
            self.stream.write("\n")
            self.stream.flush()

    def _draw(self):
        if self.stream is None:
            return
        filled = self.WIDTH * self.done // max(self.total, 1)
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] "
                          f"{self.done}/{self.total}")
        self.stream.flush()
