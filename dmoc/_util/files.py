"""Atomic file writes for everything dmoc writes (trajectories, the command line's tables,
summaries and figures): the data go to a temporary file in the target's folder, are
flushed to disk and only then renamed over the target, so a write that fails half-way
(disk full, an exception while encoding) leaves the previous file as it was. A run that
writes a set of files (`staged_run`) writes them all into a temporary folder first and
makes them the folder's set in one atomic step (`file_set`), so a failure, or a kill at
any instruction, leaves the complete previous set.

Temporaries are hidden and named ``.NAME.PID.HEX.tmp`` (``.STEM.PID.HEX.tmp.SUFFIX`` for
writers that need the suffix, ``.dmoc-run.PID.HEX.tmp/`` for a run's folder), PID the
writing process. A process killed while writing (SIGKILL, a power cut) cannot remove
them; the first save of each later process in that folder does (`remove_stale`): those
whose process no longer runs on this machine, those without a PID (older versions' names)
older than STALE_SECONDS, and those of a running process older than LIVE_STALE_SECONDS
(the PID was reused, or the process hangs). The PID is this machine's: in a folder that
several machines write at once, a save of one may remove another's temporary, whose save
then fails with an error (it never leaves a half-written file in place).
"""

import contextlib
import os
import pathlib
import re
import shutil
import time

from ..errors import InputError, MissingFileError
from . import file_set

STALE_SECONDS = 3600.0
LIVE_STALE_SECONDS = 86400.0
RUN_PREFIX = ".dmoc-run"
# .NAME.PID.HEX.tmp, optionally a suffix after it; PID absent in names of older versions
_TEMPORARY = re.compile(r"^\..+?\.(?:(\d+)\.)?[0-9a-f]{12}\.tmp(?:\.[A-Za-z0-9]+)?$")
_SWEPT = set()          # folders this process has cleaned up (once each)


def writable_file(name, path):
    """Raise InputError, naming the argument `name` and the user's `path`, unless a file
    can be written at `path`: the path must not be a folder, its folder must exist and be
    a folder (dmoc does not create folders for a single file)."""
    path = pathlib.Path(path)
    if path.is_dir():
        raise InputError(f"`{name}` must be a file name; got the folder {str(path)!r} "
                         f"(add a file name, e.g. {str(path / 'run.npz')!r}).")
    existing_folder(f"the folder of `{name}`", path.parent)
    return path


def existing_folder(name, path):
    """Raise InputError naming `name` unless `path` is an existing folder."""
    path = pathlib.Path(path)
    if path.is_dir():
        return path
    if path.exists():
        raise InputError(f"{_named(name)} must be a folder; got {str(path)!r}, which is a file.")
    raise InputError(f"{_named(name)} must be an existing folder; {str(path)!r} does not "
                     f"exist (create it first).")


def make_folder(name, path):
    """Create the folder `path` (and missing parents) unless it exists; raise InputError
    naming `name` when `path`, or the nearest existing folder above it, is a file."""
    path = pathlib.Path(path)
    existing = next(p for p in (path, *path.parents) if p.exists() or p == p.parent)
    if existing.exists() and not existing.is_dir():
        where = "" if existing == path else f" (its parent {str(existing)!r} is a file)"
        raise InputError(f"`{name}` must be a folder (created if missing); got {str(path)!r}"
                         f"{where or ', which is a file'}.")
    path.mkdir(parents=True, exist_ok=True)
    return path


def readable_file(name, path):
    """Raise MissingFileError (a FileNotFoundError) if there is nothing at `path`, and
    InputError if it is a folder; both name the argument `name` and the user's path."""
    path = pathlib.Path(path)
    if path.is_dir():
        raise InputError(f"`{name}` must be a file; got the folder {str(path)!r}.")
    if not path.exists():
        raise MissingFileError(f"`{name}` must be an existing file; there is no file {str(path)!r}.")
    return path


def _named(name):
    return name if name.startswith("the ") else f"`{name}`"


_temporary_name = file_set.temporary_name     # one format for both, the sweep's `_TEMPORARY`


@contextlib.contextmanager
def atomic_write(path, mode="wb"):
    """Open a temporary file next to `path` for writing (`mode` "wb" or "w"); when the
    block ends without an exception it replaces `path` in one rename, otherwise it is
    removed and `path` is untouched."""
    path = pathlib.Path(path)
    remove_stale(path.parent)
    temporary = path.with_name(_temporary_name(path.name))
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
    remove_stale(path.parent)
    temporary = path.with_name(_temporary_name(path.stem, path.suffix))
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


@contextlib.contextmanager
def staged_run(folder, name, replaced=()):
    """A temporary folder inside `folder` to write one run's files into; when the block
    ends without an exception they become the set `name` of `folder` in one atomic step
    (`file_set.replace`: the files of the set's earlier run, and the regular files named
    in `replaced`, go); otherwise the temporary folder is removed and `folder` is
    untouched."""
    folder = pathlib.Path(folder)
    remove_stale(folder)
    stage = folder / _temporary_name(RUN_PREFIX.lstrip("."))
    stage.mkdir()
    try:
        yield stage
        file_set.replace(folder, name, stage, replaced)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def remove_stale(folder):
    """Remove the temporaries that interrupted saves left in `folder` (see the module
    notes): those of a process that no longer runs, and the old ones.
    Done once per process and folder; errors (a folder not readable, a file removed by
    another process meanwhile) are ignored."""
    folder = pathlib.Path(folder)
    key = os.path.abspath(folder)
    if key in _SWEPT or folder.name.startswith(RUN_PREFIX):
        return
    _SWEPT.add(key)
    now = time.time()
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            found = _TEMPORARY.match(entry.name)
            if found is None:
                continue
            with contextlib.suppress(OSError):
                pid = int(found.group(1)) if found.group(1) else None
                age = now - entry.stat(follow_symlinks=False).st_mtime
                if pid is None:
                    stale = age > STALE_SECONDS
                else:
                    stale = age > LIVE_STALE_SECONDS or not _running(pid)
                if stale:
                    _remove(entry)


def _running(pid):
    """Whether process `pid` runs on this machine (always True where that cannot be asked
    without side effects, i.e. outside POSIX)."""
    if os.name != "posix" or pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True         # another user's process, or no PID at all: left to the age
    return True


def _remove(entry):
    if entry.is_dir(follow_symlinks=False):
        shutil.rmtree(entry.path)
    else:
        os.unlink(entry.path)
