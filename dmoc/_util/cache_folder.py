"""Where the compiled libraries (`compiled`: the simulator's steps, the optimizer's NLPs)
live and how they are kept: a private folder (`dmoc._util.private_folder`), each library named by the SHA-256 of its own bytes
and loaded only when its bytes still hash to that name, at most ``$DMOC_CACHE_MAX_BYTES``
of libraries (least recently used removed first), and no compile's temporary folder left
behind for long.

The folder is ``$DMOC_CACHE_DIR`` when it is set (and then only it), else
``$XDG_CACHE_HOME/dmoc`` (default ``~/.cache/dmoc``), else ``dmoc-<uid>`` in the system's
temporary folder when the first is refused or cannot be created (a read-only home, no
home at all).
"""

import hashlib
import os
import shutil
import tempfile
import time

from .private_folder import private_folder
from ..errors import CompiledCodeError

MAX_BYTES = 256 * 2**20        # default bound of the libraries' total size
STALE_SECONDS = 6 * 3600       # a compile's temporary folder older than this is abandoned
SUFFIX = ".so"


def folder():
    """The private cache folder, created if needed; `CompiledCodeError` saying why when no
    candidate is private (see the module notes)."""
    configured = os.environ.get("DMOC_CACHE_DIR")
    if configured:
        return private_folder(configured)
    home = os.path.expanduser("~")
    base = os.environ.get("XDG_CACHE_HOME") or (
        os.path.join(home, ".cache") if home != "~" else None)   # "~": no home known for this uid
    candidates = ([os.path.join(base, "dmoc")] if base else []) + [
        os.path.join(tempfile.gettempdir(), f"dmoc-{os.geteuid()}")]
    problems = []
    for candidate in candidates:
        try:
            return private_folder(candidate)
        except CompiledCodeError as err:
            problems.append(str(err))
    raise CompiledCodeError("no private folder for compiled code: " + " ".join(problems)
                            + " Set DMOC_CACHE_DIR to a folder only you can write.")


def content_hash(path):
    """SHA-256 (hex) of the bytes of file `path`."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 16), b""):
            digest.update(block)
    return digest.hexdigest()


def verified(where, prefix):
    """Path of a library ``<prefix>-<sha256>.so`` in folder `where` whose bytes hash to
    its name, its access time set to now (the least-recently-used order; the modification
time stays the compile's); None when
    there is none. A library whose bytes do not match (truncated, overwritten, damaged on
    disk) is removed, so it is compiled again."""
    for name in sorted(os.listdir(where)):
        if not (name.startswith(prefix + "-") and name.endswith(SUFFIX)):
            continue
        path = os.path.join(where, name)
        try:
            if name[len(prefix) + 1:-len(SUFFIX)] == content_hash(path):
                os.utime(path, ns=(time.time_ns(), os.stat(path).st_mtime_ns))
                return path
        except FileNotFoundError:     # evicted by another process meanwhile
            continue
        discard(path)
    return None


def publish(built, where, prefix):
    """Move the complete library `built` (a file in a temporary folder inside `where`) into
    `where` as ``<prefix>-<sha256 of its bytes>.so``, its bytes and the folder's entry on
    disk (fsync) before the name is visible; its path. Two processes publishing the same
    step at once each rename a complete file, so neither sees a partial one."""
    os.chmod(built, 0o700)
    with open(built, "rb") as file:
        os.fsync(file.fileno())
    target = os.path.join(where, f"{prefix}-{content_hash(built)}{SUFFIX}")
    os.replace(built, target)
    descriptor = os.open(where, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
    return target


def discard(path):
    """Remove file `path` if it is still there."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


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
    """Remove the least recently used libraries of folder `where` (oldest access time first,
    `keep` never) until their total size is at most `bound` bytes. A process that has one
    loaded keeps its mapping: only the name goes."""
    entries = []
    for entry in os.scandir(where):
        if entry.name.endswith(SUFFIX) and entry.is_file(follow_symlinks=False):
            info = entry.stat(follow_symlinks=False)
            entries.append((info.st_atime_ns, info.st_size, entry.path))
    total = sum(size for _, size, _ in entries)
    for _, size, path in sorted(entries):
        if total <= bound:
            return
        if path != keep:
            discard(path)
            total -= size


def remove_stale(where):
    """Remove compiles' temporary folders (``tmp*``) in `where` untouched for STALE_SECONDS:
    left by a process killed while compiling."""
    limit = time.time() - STALE_SECONDS
    for entry in os.scandir(where):
        if (entry.name.startswith("tmp") and entry.is_dir(follow_symlinks=False)
                and entry.stat(follow_symlinks=False).st_mtime < limit):
            shutil.rmtree(entry.path, ignore_errors=True)
