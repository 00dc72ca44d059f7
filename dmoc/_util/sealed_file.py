"""The bytes of a compiled library as a private anonymous file (`os.memfd_create`), sealed
against any change, and the path through which `casadi.external` loads exactly those
bytes (``/proc/self/fd/./N``: the "." keeps CasADi from appending ".so"; the path of a
descriptor of this process, which no other process can redirect). The cache folder hashes
a library's bytes read from one open file (`cache_folder.verified`) and loads these same
bytes, never the file again. Each distinct library (by its SHA-256) gets one such file,
kept open for the rest of the process: a descriptor number closed and reused would give
the dynamic loader, which knows a loaded library by its path, the earlier library for a
new one.
"""

import fcntl
import os

_SEALS = (getattr(fcntl, "F_SEAL_WRITE", 0) | getattr(fcntl, "F_SEAL_GROW", 0)
          | getattr(fcntl, "F_SEAL_SHRINK", 0) | getattr(fcntl, "F_SEAL_SEAL", 0))
_OPEN = {}      # sha256 of the bytes -> the path of their sealed file


def available():
    """True where libraries can be loaded from anonymous files (Linux)."""
    return hasattr(os, "memfd_create") and os.path.isdir("/proc/self/fd")


def sealed_path(data, digest):
    """The path of a sealed anonymous file holding the bytes `data`, whose SHA-256 (hex)
    is `digest` (the caller has it: the cache folder hashed these bytes to verify them;
    see the module notes); the same path for the same bytes."""
    if digest not in _OPEN:
        fd = os.memfd_create("dmoc-library", os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            fcntl.fcntl(fd, fcntl.F_ADD_SEALS, _SEALS)
        except BaseException:
            os.close(fd)
            raise
        _OPEN[digest] = f"/proc/self/fd/./{fd}"
    return _OPEN[digest]
