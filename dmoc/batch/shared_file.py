"""The worker's side of the shared-memory exchange of a chunk of `simulate_many`
(`dmoc.batch.sharing`, where the client's side and the slot's file are): a `SharedFile`
opens a slot the client lends through ``/proc/<pid>/fd/<fd>``, checks its token, locks it
(``flock``), writes the chunk's packed arrays into it and marks it with a random ticket;
a worker keeps the descriptors and mappings of the slots it opened for the client of the
batch (`_opened`).
"""

import fcntl
import mmap
import os
import secrets
import threading
import weakref

import numpy as np

from .sharing import FREE, HEADER, SLOTS, STATE, TOKEN, holds_token, reach_slot


class SharedFile:
    """A worker's slot for the arrays of one chunk (`allocate`), when `share`, the client's
    `sharing.Exchange`, reaches this worker and the arrays reach `sharing.MIN_BYTES`.
    `path` and `layout` name them once `seal` has marked them: ``path = (pid, fd, token,
    ticket)``, ``layout[name] = (offset, dtype, shape)``."""

    def __init__(self, share):
        self.share, self.path, self.layout, self._held = share, None, None, None

    def allocate(self, shapes):
        """{name: writable array of shapes[name] = (shape, dtype)} in a free slot of the
        client, held (locked) until `seal` or `release`, or None where there is none."""
        layout, size = {}, 0
        for name, (shape, dtype) in shapes.items():
            layout[name] = (size, np.dtype(dtype).str, tuple(shape))
            size += np.dtype(dtype).itemsize * int(np.prod(shape))
        if self.share is None or size < max(self.share[2], 1):
            return None
        pid, slots, _ = self.share
        for fd, token in slots:
            opened = _opened(pid, fd, token)
            memory = opened.hold(HEADER + size) if opened is not None else None
            if memory is not None:
                self._held, self.layout = (opened, (pid, fd, token)), layout
                return {name: _view(memory, offset + HEADER, dtype, shape)
                        for name, (offset, dtype, shape) in layout.items()}
        return None

    def seal(self):
        """Whether the arrays went to a slot the client will read: the slot is marked with
        a new ticket and let go."""
        if self._held is None:
            return False
        (opened, where), ticket = self._held, FREE
        while ticket == FREE:
            ticket = secrets.token_bytes(STATE)
        opened.let_go(ticket)
        self._held, self.path = None, (*where, ticket)
        return True

    def release(self):
        """Let go of a slot taken by `allocate` and not sealed (its arrays not sent)."""
        if self._held is not None:
            self._held[0].let_go(FREE)
            self._held = None


class _Opened:
    """A worker's descriptor and mapping of one slot of a client."""

    def __init__(self, fd):
        self.fd, self.memory, self.lock = fd, None, threading.Lock()
        weakref.finalize(self, os.close, fd)     # when no chunk in writing holds it either

    def hold(self, size):
        """The slot's mapping of at least `size` bytes, locked (against the other threads of
        this process, and with ``flock`` the other processes), if it is free; else None."""
        if not self.lock.acquire(blocking=False):
            return None
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.lock.release()
            return None
        try:
            if os.pread(self.fd, STATE, TOKEN) == FREE:
                if os.fstat(self.fd).st_size < size:
                    # reserved, not only sized: a full memory then fails here instead of
                    # killing the worker with SIGBUS when it writes
                    os.posix_fallocate(self.fd, 0, size)
                if self.memory is None or len(self.memory) < size:
                    self.memory = mmap.mmap(self.fd, size)
                return self.memory
        except OSError:
            pass
        fcntl.flock(self.fd, fcntl.LOCK_UN)
        self.lock.release()
        return None

    def let_go(self, state):
        """Write the slot's `state` and unlock it."""
        try:
            os.pwrite(self.fd, state, TOKEN)
        finally:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            self.lock.release()


# (pid, fd, token) -> _Opened (or None: not this client's slot), of one client process at a
# time and at most 2 SLOTS of them: the mappings of other slots are dropped then
_OPENED = {}
_OPENED_LOCK = threading.Lock()


def _opened(pid, fd, token):
    """This worker's `_Opened` slot `fd` of the client process `pid`, or None when it is
    not that client's slot of this `token` (another machine or process namespace)."""
    key = (pid, fd, token)
    with _OPENED_LOCK:
        if key not in _OPENED:
            if len(_OPENED) >= 2 * SLOTS or any(other[0] != pid for other in _OPENED):
                _OPENED.clear()
            _OPENED[key] = _open(pid, fd, token)
        return _OPENED[key]


def _open(pid, fd, token):
    """`_Opened` of ``/proc/<pid>/fd/<fd>`` if it is a file of this user that starts with
    `token`, else None."""
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


def _view(memory, offset, dtype, shape):
    return np.frombuffer(memory, dtype, int(np.prod(shape)), offset).reshape(shape)
