"""Atomic file writes for everything dmoc writes (trajectories, the command line's tables,
summaries and figures): the data go to a temporary file in the target's folder, are
flushed to disk and only then renamed over the target, so a write that fails half-way
(disk full, an exception while encoding) leaves the previous file as it was.
"""

import contextlib
import os
import pathlib
import uuid


@contextlib.contextmanager
def atomic_write(path, mode="wb"):
    """Open a temporary file next to `path` for writing (`mode` "wb" or "w"); when the
    block ends without an exception it replaces `path` in one rename, otherwise it is
    removed and `path` is untouched."""
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex[:12]}.tmp")
    # os.open with mode 0o666 gives the permissions of a plain open(): 0o666 less umask.
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(descriptor, mode) as file:
            yield file
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


@contextlib.contextmanager
def atomic_path(path):
    """A temporary path next to `path` for a writer that takes a file name (matplotlib's
    animation writers); renamed over `path` when the block ends without an exception."""
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:12]}{path.suffix}")
    try:
        yield temporary
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


def write_text(path, text):
    """Write `text` to `path` atomically."""
    with atomic_write(path, "w") as file:
        file.write(text)
