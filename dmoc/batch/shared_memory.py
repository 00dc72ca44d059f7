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
arrays go through Dask. The client's results keep the slot's pages (`read`: a private
mapping, no copy) and a new file takes the slot's place; the file comes back to the pool
when the results are gone. The file holds numbers only: nothing in it is unpickled or run.
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

# A slot's file: its token (16 bytes), its state (8 bytes: FREE, the ticket of the chunk
# written there and not yet read, or TAKEN while the client's results hold its pages),
# then from HEADER on the chunk's arrays.
TOKEN, STATE, HEADER = 16, 8, 64
FREE, TAKEN = bytes(STATE), b"\xff" * STATE

_POOL = []                       # the client's free Slots, of the process `_POOL_PID`
_POOL_PID = [os.getpid()]        # (a process forked from the client makes a pool of its own)
_POOL_LOCK = threading.Lock()
_LENDING = {}                    # fd -> (Exchange, Slot) of the slots lent by open Exchanges
_HELD = [0]                      # taken slots kept open to join the pool again (<= 2 SLOTS)


class Slot:
    """A memfd of the client's process: its descriptor `fd`, the random `token` at its start."""

    def __init__(self, token=None):
        self.fd = os.memfd_create("dmoc-batch", os.MFD_CLOEXEC)
        self.token = secrets.token_bytes(TOKEN) if token is None else token
        os.pwrite(self.fd, self.token + FREE, 0)

    def reset(self):
        """Mark the slot free; False when a writer holds it (then it is closed)."""
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self.fd)
            return False
        try:
            os.pwrite(self.fd, FREE, TOKEN)
            return True
        finally:
            fcntl.flock(self.fd, fcntl.LOCK_UN)


def _pooled(slots):
    """Put the free `slots` in the pool, which keeps the largest first: at most 2 SLOTS
    slots and `KEPT_BYTES` of them, the others emptied (beyond the bytes) or closed
    (beyond the count); in another process than the pool's, close them."""
    with _POOL_LOCK:
        if _POOL_PID[0] != os.getpid():
            for slot in slots:
                os.close(slot.fd)
            return
        sized = sorted(((os.fstat(slot.fd).st_size, slot) for slot in _POOL + list(slots)),
                       key=lambda pair: -pair[0])
        _POOL.clear()
        kept = 0
        for size, slot in sized:
            if len(_POOL) >= 2 * SLOTS:
                os.close(slot.fd)
                continue
            if kept + size > KEPT_BYTES and size > HEADER:
                os.ftruncate(slot.fd, HEADER)
                size = HEADER
            kept += size
            _POOL.append(slot)


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
                _LENDING.clear()
                _HELD[0] = 0
                _POOL_PID[0] = os.getpid()
            self.slots = _POOL[:SLOTS]
            del _POOL[:SLOTS]
        try:
            while len(self.slots) < SLOTS:
                self.slots.append(Slot())
        except OSError:          # no memory for a file now: Dask carries the rest
            if not self.slots:
                return None
        with _POOL_LOCK:
            _LENDING.update((slot.fd, (self, slot)) for slot in self.slots)
        return os.getpid(), tuple((slot.fd, slot.token) for slot in self.slots), MIN_BYTES

    def __exit__(self, *exc):
        with _POOL_LOCK:
            for slot in self.slots:
                _LENDING.pop(slot.fd, None)
        _pooled([slot for slot in self.slots if slot.reset()])
        self.slots = []

    def hand_over(self, slot):
        """A descriptor of `slot`'s file, whose pages a client's results keep from now on,
        and a new file under `slot`'s descriptor and token for the rest of the batch (the
        workers reach it as the same slot). OSError when there is no memory for a file."""
        fresh = Slot(slot.token)
        try:
            taken = os.dup(slot.fd)
            try:
                os.dup2(fresh.fd, slot.fd, inheritable=False)
            except OSError:
                os.close(taken)
                raise
        finally:
            os.close(fresh.fd)
        return taken


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
    one buffer of this process (one per chunk), after which the slot takes the next chunk.
    OSError when the slot is not the client's of this token and ticket, is too small for
    the layout, or the layout places anything but arrays of numbers.

    A slot an `Exchange` of this process lends is taken (`_taken`): the buffer is a
    private mapping of its pages, not a copy, and a new file takes its place in the
    batch; elsewhere (a slot of no open Exchange) the arrays are copied out and the slot
    is free again."""
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
        buffer = _taken(handle, pid, fd, size)
        if buffer is None:
            buffer = np.empty(size, np.uint8)
            _read_into(handle, memoryview(buffer), HEADER)
            os.pwrite(handle, FREE, TOKEN)
    finally:
        os.close(handle)
    return {name: buffer[start:stop].view(dtype).reshape(shape)
            for name, (start, stop, dtype, shape) in spans.items()}


def _taken(handle, pid, fd, size):
    """The `size` bytes after HEADER of the slot open as `handle`, which an Exchange of
    this process lends, as a private (copy-on-write) mapping of its pages, writable: the
    slot is marked TAKEN, so no worker writes there while the mapping lives, and its
    Exchange puts a new file under its descriptor (`Exchange.hand_over`). When the
    mapping goes (no array of the results is left) the file joins the pool again, free,
    with the pages the workers have mapped already (`_pooled`), if at most 2 SLOTS taken
    files are kept open for that; else its descriptor is closed now. None (copy the arrays instead) where no Exchange of
    this process lends the slot or no new file can be made."""
    with _POOL_LOCK:
        lent = _LENDING.get(fd) if pid == os.getpid() == _POOL_PID[0] else None
    if lent is None:
        return None
    exchange, slot = lent
    try:
        taken = exchange.hand_over(slot)
    except OSError:
        return None
    os.pwrite(handle, TAKEN, TOKEN)
    memory = mmap.mmap(handle, HEADER + size, flags=mmap.MAP_PRIVATE)
    with _POOL_LOCK:
        kept = _HELD[0] < 2 * SLOTS
        _HELD[0] += kept
    if kept:
        weakref.finalize(memory, _returned, taken, slot.token)
    else:
        os.close(taken)
    return np.frombuffer(memory, np.uint8, size, HEADER)


def _returned(fd, token):
    """The results holding the pages of the slot file `fd` of `token` are gone: it joins
    the pool, free (`_pooled`)."""
    with _POOL_LOCK:
        _HELD[0] -= 1
        ours = _POOL_PID[0] == os.getpid()
    if not ours:                        # a forked child's copy of the results
        os.close(fd)
        return
    slot = Slot.__new__(Slot)
    slot.fd, slot.token = fd, token
    os.pwrite(fd, FREE, TOKEN)
    _pooled([slot])


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
