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
and takes the slot's lock (``flock``) writes a chunk's arrays into it
(`dmoc.batch.slot_writer.SharedFile`, the worker's side), marks
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
    (pid, ((fd, token), ...), MIN_BYTES) a worker's `slot_writer.SharedFile` takes, or
    None without memfd or /proc; on exit the slots are freed and go back to the pool
    (`_pooled`)."""

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
    """The arrays a `slot_writer.SharedFile` put in the slot `path` = (pid, fd, token,
    ticket), views of one buffer of this process (one per chunk), after which the slot
    takes the next chunk.
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
    files are kept open for that; else its descriptor is closed now. None (copy the
    arrays instead) where no Exchange of this process lends the slot or no new file can
    be made."""
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
