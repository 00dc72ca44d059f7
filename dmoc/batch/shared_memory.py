"""dmoc's one protocol of its own beside Dask: the packed trajectories of a chunk of
`simulate_many` (`dmoc.batch.packing`) reach a client on the worker's machine through
shared memory that both reuse from batch to batch, instead of Dask's TCP frames, which
leave `simulate_many` short of its target speed-up (`benchmarks/batch.py`; the figure is
in docs/performance.md, `batch.py`).

The client owns the memory: a pool of `Slot`s, anonymous shared-memory files (memfd) that
only its process holds, kept up to `KEPT_BYTES` and gone with the process. For a batch it
lends `SLOTS` of them (`Exchange`) and tells the workers its pid and, per slot, the
descriptor and a random token written at the file's start. A worker that can open a slot
through ``/proc/<pid>/fd/<fd>`` (the kernel allows the same user only), finds the token
and takes the slot's lock (``flock``) writes a chunk's arrays into it (`SharedFile`), marks
it with a random ticket and sends only the slot, the ticket and the layout; anywhere else
(another machine, namespace or user, every slot busy, a chunk under `MIN_BYTES`) the
arrays go through Dask. The client copies the arrays out (`read`) and frees the slot. The
file holds numbers only: nothing in it is unpickled or run.
"""

import fcntl
import math
import mmap
import os
import secrets
import stat
import threading
import weakref

import numpy as np

# Chunks whose arrays are smaller travel through Dask: a slot costs a few system calls.
MIN_BYTES = 1 << 20

# Slots one batch borrows (a slot is free again once the client has read it, so a few
# per worker suffice; an unused slot is an empty file).
SLOTS = 8

# Bytes of slots the client keeps between batches (the rest are emptied): a batch of 1000
# runs of 1000 knife-edge steps on 2 workers fills 4 slots of 22 MB, which the next batch
# then writes into without the kernel handing out (zeroed) memory again.
KEPT_BYTES = 1 << 27

# A slot's file grows in steps of GRAIN bytes (its mapping with it), so that a chunk's
# arrays, written group by group, remap it a few times, not once per group.
GRAIN = 1 << 22

# A slot's file: its token (16 bytes), its state (8 bytes: FREE, or the ticket of the chunk
# written there and not yet read), then from HEADER on the chunk's arrays.
TOKEN, STATE, HEADER = 16, 8, 64
FREE = bytes(STATE)

_POOL = []                       # the client's free Slots, of the process `_POOL_PID`
_POOL_PID = [os.getpid()]        # (a process forked from the client makes a pool of its own)
_POOL_LOCK = threading.Lock()


class Slot:
    """A memfd of the client's process: its descriptor `fd`, the random `token` at its start."""

    def __init__(self):
        self.fd = os.memfd_create("dmoc-batch", os.MFD_CLOEXEC)
        self.token = secrets.token_bytes(TOKEN)
        os.pwrite(self.fd, self.token + FREE, 0)

    def reset(self, kept):
        """Mark the slot free and empty it when `kept` bytes of slots are kept already; its
        size (bytes), or None when a writer holds it (then it is closed, not kept)."""
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self.fd)
            return None
        try:
            os.pwrite(self.fd, FREE, TOKEN)
            size = os.fstat(self.fd).st_size
            if kept + size > KEPT_BYTES and size > HEADER:
                os.ftruncate(self.fd, HEADER)
                size = HEADER
            return size
        finally:
            fcntl.flock(self.fd, fcntl.LOCK_UN)


class Exchange:
    """The client's side of one batch: ``with Exchange() as share:`` gives the value
    (pid, ((fd, token), ...), MIN_BYTES) a worker's `SharedFile` takes, or None without
    memfd or /proc; on exit the slots are freed and go back to the pool (`KEPT_BYTES`)."""

    def __init__(self):
        self.slots = []

    def __enter__(self):
        if not hasattr(os, "memfd_create") or not os.path.isdir(f"/proc/{os.getpid()}/fd"):
            return None
        with _POOL_LOCK:
            if _POOL_PID[0] != os.getpid():
                for slot in _POOL:
                    os.close(slot.fd)            # this process's copy of the parent's slot
                _POOL.clear()
                _POOL_PID[0] = os.getpid()
            self.slots = _POOL[:SLOTS]
            del _POOL[:SLOTS]
        try:
            while len(self.slots) < SLOTS:
                self.slots.append(Slot())
        except OSError:          # no memory for a file now: Dask carries the rest
            if not self.slots:
                return None
        return os.getpid(), tuple((slot.fd, slot.token) for slot in self.slots), MIN_BYTES

    def __exit__(self, *exc):
        kept, returned = 0, []
        for slot in self.slots:
            size = slot.reset(kept)
            if size is not None:
                kept += size
                returned.append(slot)
        with _POOL_LOCK:
            _POOL.extend(returned)
        self.slots = []


def reach_slot(pid, fd):
    """A descriptor of ``/proc/<pid>/fd/<fd>``, checked to be this user's regular file first."""
    path = f"/proc/{pid}/fd/{fd}"
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_uid != os.getuid():
            return None
        return os.open(path, os.O_RDWR | os.O_CLOEXEC | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError:
        return None


def holds_token(handle, token):
    """Whether the open file `handle` is a regular file of this user starting with `token`."""
    info = os.fstat(handle)
    return (stat.S_ISREG(info.st_mode) and info.st_uid == os.getuid()
            and os.pread(handle, TOKEN, 0) == token)


def read(path, layout):
    """The arrays a `SharedFile` put in the slot `path` = (pid, fd, token, ticket), views of
    one new buffer of this process they are copied into (one read per chunk); the slot is
    then free. OSError when the slot is not the client's of this token and ticket, is too
    small for the layout, or the layout places anything but arrays of numbers."""
    pid, fd, token, ticket = path
    handle = reach_slot(pid, fd)
    refused = OSError(f"/proc/{pid}/fd/{fd} is not a slot of this batch holding that chunk")
    if handle is None:
        raise refused
    try:
        spans = _spans(layout)
        size = max((stop for _, stop, _, _ in spans.values()), default=0)
        if (not holds_token(handle, token) or os.pread(handle, STATE, TOKEN) != ticket
                or os.fstat(handle).st_size < HEADER + size):
            raise refused
        buffer = np.empty(size, np.uint8)
        _read_into(handle, memoryview(buffer), HEADER)
        os.pwrite(handle, FREE, TOKEN)
    finally:
        os.close(handle)
    return {name: buffer[start:stop].view(dtype).reshape(shape)
            for name, (start, stop, dtype, shape) in spans.items()}


def _spans(layout):
    """{name: (start, stop, dtype, shape)} of the arrays `layout` places in a slot, after
    its header; OSError (a slot refused) unless each is an array of numbers at an offset
    >= 0."""
    spans = {}
    for name, (offset, dtype, shape) in layout.items():
        dtype, shape = np.dtype(dtype), tuple(int(n) for n in shape)
        if dtype.kind not in "biufc" or offset < 0 or min(shape, default=0) < 0:
            raise OSError(f"a slot's layout must place arrays of numbers; got {name!r}: "
                          f"{(offset, dtype.str, shape)}")
        spans[name] = (offset, offset + dtype.itemsize * math.prod(shape), dtype, shape)
    return spans


def _read_into(handle, buffer, offset):
    while len(buffer):
        count = os.preadv(handle, [buffer], offset)
        if count <= 0:
            raise OSError("a slot ended before its arrays")
        buffer, offset = buffer[count:], offset + count


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
        while ticket == FREE:
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
    """A worker's descriptor and mapping of one slot of a client."""

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


# (pid, fd, token) -> _Opened or None (not the client's), of one client at a time, <= 2 SLOTS
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
    """This worker's `_Opened` slot `fd` of the client `pid`, or None where it is not that
    client's slot of this `token` (another machine or process namespace)."""
    key = (pid, fd, token)
    with _OPENED_LOCK:
        if key not in _OPENED:
            if len(_OPENED) >= 2 * SLOTS or any(other[0] != pid for other in _OPENED):
                _OPENED.clear()
            _OPENED[key] = _open(pid, fd, token)
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
