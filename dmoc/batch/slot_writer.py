"""A worker's side of dmoc's shared-memory exchange (`dmoc.batch.shared_memory`, which
describes the protocol): taking a free slot of the client's pool, growing it as a chunk's
arrays are written, and sealing it for the client (`SharedFile`). A worker keeps its
mappings of a client's slots between chunks, knows a slot's file by its inode, and takes
the slots it has mapped before first, so that its chunks write into pages it has mapped
already.
"""

import fcntl
import mmap
import os
import secrets
import threading
import weakref

from .shared_memory import (FREE, GRAIN, HEADER, SLOTS, STATE, TAKEN, TOKEN, holds_token,
                            reach_slot)


class SharedFile:
    """A worker's slot for the arrays of one chunk, when `share`, the client's `Exchange`,
    reaches this worker: held (locked) from the first `reserve` that finds a free slot
    until `seal` or `release`, grown by each later `reserve` as the chunk's arrays are
    written; once sealed, ``path = (pid, fd, token, ticket)`` and ``layout[name] =
    (offset, dtype, shape)``. An instance that goes away still holding its slot lets it
    go."""

    def __init__(self, share):
        self.share, self.path, self.layout, self._held = share, None, None, None

    def reserve(self, size):
        """A writable mapping of the slot held, at least `HEADER` + `size` bytes long (the
        arrays start at `HEADER`): the slot held, grown if need be, or else a free slot of
        the client when `size` reaches `MIN_BYTES`, one this process has mapped before
        first (`_known_first`); None where there is none (no share, a smaller `size`,
        every slot busy, no memory for it). The mappings of earlier calls stay valid (the
        same file): what was written through them stays in the slot."""
        if self._held is not None:
            return self._held[0].grow(HEADER + size)
        if self.share is None or size < max(self.share[2], 1):
            return None
        pid, slots, _ = self.share
        for fd, token, opened in _known_first(pid, slots):
            memory = opened.hold(HEADER + size) if opened is not None else None
            if memory is not None:
                self._held = (opened, (pid, fd, token))
                self._finalizer = weakref.finalize(self, _Opened.let_go, opened, FREE)
                return memory
        return None

    @property
    def held(self):
        """Whether this chunk holds a slot (`reserve` found one; not sealed or released)."""
        return self._held is not None

    def seal(self, layout):
        """Whether the arrays `layout` places (``{name: (offset after HEADER, dtype,
        shape)}``) went to a slot the client will read: the slot is marked with a new
        ticket and let go."""
        if self._held is None:
            return False
        (opened, where), ticket = self._held, FREE
        while ticket in (FREE, TAKEN):
            ticket = secrets.token_bytes(STATE)
        self._finalizer.detach()
        opened.let_go(ticket)
        self._held, self.path, self.layout = None, (*where, ticket), layout
        return True

    def release(self):
        """Let go of a slot taken by `reserve` and not sealed (its arrays not sent)."""
        if self._held is not None:
            self._finalizer.detach()
            self._held[0].let_go(FREE)
            self._held = None


class _Opened:
    """A worker's descriptor and mappings of one slot file of a client."""

    def __init__(self, fd):
        self.fd, self.mappings, self.lock = fd, [], threading.Lock()
        weakref.finalize(self, os.close, fd)     # when no chunk in writing holds it either

    def hold(self, size):
        """The slot's mapping of at least `size` bytes, locked (threads, and processes by
        ``flock``), if it is free; else None."""
        if not self.lock.acquire(blocking=False):
            return None
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.lock.release()
            return None
        try:
            if os.pread(self.fd, STATE, TOKEN) == FREE:
                return self._mapped(size)
        except OSError:
            pass
        fcntl.flock(self.fd, fcntl.LOCK_UN)
        self.lock.release()
        return None

    def grow(self, size):
        """The held slot's mapping of at least `size` bytes, or None when there is no memory
        for it (the slot stays held, as it was)."""
        try:
            return self._mapped(size)
        except OSError:
            return None

    def _mapped(self, size):
        """The shortest of this process's mappings of the slot at least `size` bytes long,
        the file first reserved that large, in steps of GRAIN (no SIGBUS on a full
        memory); a new mapping of the whole file when it grew past them all. Every mapping
        is kept, so a page is written through the same mapping from chunk to chunk and
        stays mapped in this process: a mapping made anew would fault in every page again."""
        length = os.fstat(self.fd).st_size
        if length < size:
            length = -(-size // GRAIN) * GRAIN
            os.posix_fallocate(self.fd, 0, length)
        for memory in self.mappings:
            if len(memory) >= size:
                return memory
        self.mappings.append(mmap.mmap(self.fd, length))
        return self.mappings[-1]

    def let_go(self, state):
        """Write the slot's `state` and unlock it."""
        try:
            os.pwrite(self.fd, state, TOKEN)
        finally:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            self.lock.release()


# (pid, fd, token) -> the inode there, and (pid, inode, token) -> _Opened or None (not the
# client's): of one client at a time, up to 4 SLOTS. A file is known by its inode, so a
# slot whose file the client handed to its results is opened anew, and a file that comes
# back to the pool under another descriptor is the mapping this worker has already.
_OPENED = {}
_OPENED_LOCK = threading.Lock()


def _known_first(pid, slots):
    """(fd, token, `_Opened` or None) of each of the client's `slots`, those this process
    has mapped first, the largest first: their pages are mapped here already, so writing a
    chunk there costs no page faults (a worker keeps to a few slots of its own)."""
    opened = [(fd, token, _opened(pid, fd, token)) for fd, token in slots]
    return sorted(opened, key=lambda slot: -len(slot[2].mappings[-1])
                  if slot[2] and slot[2].mappings else 0)


def _opened(pid, fd, token):
    """This worker's `_Opened` of the file under the slot `fd` of the client `pid`, or None
    where it is not that client's slot of this `token` (another machine or process
    namespace)."""
    try:
        key = (pid, os.stat(f"/proc/{pid}/fd/{fd}").st_ino, token)
    except OSError:
        return None
    with _OPENED_LOCK:
        if key not in _OPENED:
            if any(other[0] != pid for other in _OPENED):
                _OPENED.clear()
            if len(_OPENED) >= 4 * SLOTS:       # files never written here go first
                for other in [k for k, o in _OPENED.items() if o is None or not o.mappings]:
                    del _OPENED[other]
            if len(_OPENED) >= 4 * SLOTS:
                _OPENED.clear()
            opened = _open(pid, fd, token)
            if opened is not None and os.fstat(opened.fd).st_ino != key[1]:
                return None             # the file changed meanwhile: not cached
            _OPENED[key] = opened
        return _OPENED[key]


def _open(pid, fd, token):
    """`_Opened` of ``/proc/<pid>/fd/<fd>`` if it is this user's file starting with `token`."""
    handle = reach_slot(pid, fd)
    try:
        trusted = handle is not None and holds_token(handle, token)
    except OSError:
        trusted = False
    if trusted:
        return _Opened(handle)
    if handle is not None:
        os.close(handle)
    return None
