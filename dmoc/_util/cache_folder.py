"""Where the compiled libraries (`compiled`: the simulator's steps, the optimizer's NLPs)
live and how they are kept: a private folder (`dmoc._util.private_folder`) worked through
one open descriptor (every file opened, listed, renamed and removed relative to it, so no
path swapped meanwhile redirects any of it), each library named by the SHA-256 of its own
bytes and used only as the bytes read from one open file that hash to that name (what is
hashed is what is loaded: `sealed_file`), at most ``$DMOC_CACHE_MAX_BYTES`` of libraries
(least recently used removed first), and no compile's temporary folder left behind for
long. A file in the folder that is not this uid's own private regular file with one link
(put there by root or another account, or a hard link) is removed with one warning, or
skipped with it when it cannot be.

The folder is ``$DMOC_CACHE_DIR`` when it is set (and then only it), else
``$XDG_CACHE_HOME/dmoc`` (default ``~/.cache/dmoc``), else ``dmoc-<uid>`` in the system's
temporary folder when the first is refused or cannot be created (a read-only home, no
home at all).
"""

import contextlib
import hashlib
import os
import shutil
import stat
import tempfile
import time
import warnings
from typing import NamedTuple

from .private_folder import private_folder
from ..errors import CompiledCodeError

MAX_BYTES = 256 * 2**20        # default bound of the libraries' total size
STALE_SECONDS = 6 * 3600       # a compile's temporary folder older than this is abandoned
SUFFIX = ".so"
_FILE = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
_WARNED = set()                # (folder, name) of the foreign files warned about


class Folder(NamedTuple):
    """The cache folder: its real `path` (for messages) and the descriptor `fd` every
    operation goes through."""
    path: str
    fd: int


@contextlib.contextmanager
def opened():
    """The private cache folder as a `Folder`, created if needed, its descriptor closed
    after the block; `CompiledCodeError` saying why when no candidate is private (see the
    module notes)."""
    configured = os.environ.get("DMOC_CACHE_DIR")
    if configured:
        candidates = [configured]
    else:
        home = os.path.expanduser("~")
        base = os.environ.get("XDG_CACHE_HOME") or (
            os.path.join(home, ".cache") if home != "~" else None)   # "~": no home for this uid
        candidates = ([os.path.join(base, "dmoc")] if base else []) + [
            os.path.join(tempfile.gettempdir(), f"dmoc-{os.geteuid()}")]
    problems = []
    for candidate in candidates:
        try:
            path, fd = private_folder(candidate)
            break
        except CompiledCodeError as err:
            problems.append(str(err))
    else:
        raise CompiledCodeError(problems[0] if configured else "no private folder for compiled "
                                "code: " + " ".join(problems) + " Set DMOC_CACHE_DIR to a "
                                "folder only you can write.")
    try:
        yield Folder(path, fd)
    finally:
        os.close(fd)


def verified(where, prefix):
    """(name, bytes) of a library ``<prefix>-<sha256>.so`` in the `Folder` `where` whose
    bytes, read from one open file, hash to its name, its access time set to now (the
    least-recently-used order; the modification time stays the compile's); None when there
    is none. A library whose bytes do not match (truncated, overwritten, damaged on disk)
    is removed, so it is compiled again; so is a foreign file (see the module notes)."""
    for name in sorted(os.listdir(where.fd)):
        if not (name.startswith(prefix + "-") and name.endswith(SUFFIX)):
            continue
        try:
            data = _own_bytes(where, name)
        except FileNotFoundError:     # evicted by another process meanwhile
            continue
        if data is not None and name[len(prefix) + 1:-len(SUFFIX)] == _sha256(data):
            return name, data
        if data is not None:
            discard(where, name)
    return None


def _own_bytes(where, name):
    """The bytes of file `name` in `where` when it is this uid's own private regular file
    with one link (its access time set to now), else None after removing it, or skipping
    it when it cannot be removed, with one warning."""
    fd = os.open(name, _FILE, dir_fd=where.fd)
    try:
        info = os.fstat(fd)
        foreign = (not stat.S_ISREG(info.st_mode) or info.st_uid != os.geteuid()
                   or info.st_nlink != 1 or info.st_mode & 0o022)
        if not foreign:
            data = _read_all(fd, info.st_size)
            os.utime(fd, ns=(time.time_ns(), info.st_mtime_ns))
            return data
    finally:
        os.close(fd)
    _foreign(where, name, info)
    return None


def _foreign(where, name, info):
    """Remove the foreign file `name` (fstat `info`) of `where`, warning once."""
    what = (f"belongs to uid {info.st_uid}" if info.st_uid != os.geteuid() else
            f"has {info.st_nlink} links" if info.st_nlink != 1 else
            f"has mode {stat.S_IMODE(info.st_mode):04o}" if stat.S_ISREG(info.st_mode) else
            "is not a regular file")
    try:
        os.unlink(name, dir_fd=where.fd)
        done = "it was removed"
    except OSError as err:
        done = f"it could not be removed ({err.strerror}) and is skipped"
    if (where.path, name) not in _WARNED:
        _WARNED.add((where.path, name))
        warnings.warn(f"the compiled-code cache {where.path} held {name}, which {what}: dmoc "
                      f"loads no code from it; {done}.", RuntimeWarning, stacklevel=4)


def _read_all(fd, size):
    """Every byte of the open file `fd` (`size` expected, more read if it grew)."""
    chunks, total = [], 0
    while True:
        chunk = os.read(fd, max(size - total, 1 << 16))
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)
        total += len(chunk)


def _sha256(data):
    return hashlib.sha256(data).hexdigest()


def publish(where, work, built, prefix):
    """Move the complete library `built` (a file in the folder open as `work`, a temporary
    folder inside the `Folder` `where`) into `where` as ``<prefix>-<sha256 of its
    bytes>.so``, its bytes and the folder's entry on disk (fsync) before the name is
    visible; (its name, the bytes hashed). Two processes publishing the same step at once
    each rename a complete file, so neither sees a partial one."""
    fd = os.open(built, _FILE, dir_fd=work)
    try:
        os.fchmod(fd, 0o700)
        data = _read_all(fd, os.fstat(fd).st_size)
        os.fsync(fd)
    finally:
        os.close(fd)
    name = f"{prefix}-{_sha256(data)}{SUFFIX}"
    os.replace(built, name, src_dir_fd=work, dst_dir_fd=where.fd)
    os.fsync(where.fd)
    return name, data


def discard(where, name):
    """Remove file `name` of the `Folder` `where` if it is still there."""
    with contextlib.suppress(FileNotFoundError):
        os.unlink(name, dir_fd=where.fd)


def max_bytes():
    """The bound on the libraries' total size: ``$DMOC_CACHE_MAX_BYTES`` (a whole number of
    bytes), else MAX_BYTES."""
    text = os.environ.get("DMOC_CACHE_MAX_BYTES", "")
    if not text:
        return MAX_BYTES
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise CompiledCodeError(f"`DMOC_CACHE_MAX_BYTES` must be a whole number of bytes >= 0; "
                                f"got {text!r}.")
    return value


def evict(where, keep, bound):
    """Remove the least recently used libraries of the `Folder` `where` (oldest access time
    first, the name `keep` never) until their total size is at most `bound` bytes. A
    process that has one loaded keeps its copy: only the name goes."""
    entries = []
    for name in os.listdir(where.fd):
        if name.endswith(SUFFIX):
            with contextlib.suppress(FileNotFoundError):
                info = os.stat(name, dir_fd=where.fd, follow_symlinks=False)
                if stat.S_ISREG(info.st_mode):
                    entries.append((info.st_atime_ns, info.st_size, name))
    total = sum(size for _, size, _ in entries)
    for _, size, name in sorted(entries):
        if total <= bound:
            return
        if name != keep:
            discard(where, name)
            total -= size


def remove_stale(where):
    """Remove compiles' temporary folders (``tmp*``) in the `Folder` `where` untouched for
    STALE_SECONDS: left by a process killed while compiling."""
    limit = time.time() - STALE_SECONDS
    for name in os.listdir(where.fd):
        if not name.startswith("tmp"):
            continue
        with contextlib.suppress(FileNotFoundError):
            info = os.stat(name, dir_fd=where.fd, follow_symlinks=False)
            if stat.S_ISDIR(info.st_mode) and info.st_mtime < limit:
                shutil.rmtree(name, dir_fd=where.fd, ignore_errors=True)
