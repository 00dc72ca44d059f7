"""How the packed trajectories of a chunk of `simulate_many` (`dmoc.batch.packing`) reach
a client on the same machine as their worker: through shared memory that both reuse from
batch to batch, instead of Dask's TCP frames, which cost about a quarter of a batch of 1000
runs of 1000 steps, or new pages each time, which cost many times the copy of the data
(benchmarks/batch.py, benchmarks/batch_worker.py).

The client owns the memory: a pool of `Slot`s, anonymous shared-memory files (memfd) that
only its process holds, kept from batch to batch up to `KEPT_BYTES` and gone with the
process. For the length of a batch it lends `SLOTS` of them (`Exchange`) and tells the
workers its process id and, per slot, the descriptor and a random token written at the
start of the file. A worker that can open the slot through ``/proc/<pid>/fd/<fd>`` (the
kernel allows that to the same user only), finds the token there and takes the slot's
lock (``flock``), writes a chunk's arrays into it, marks it with a random ticket and sends
only the slot, the ticket and the layout. Any other worker (another machine, another
process namespace, another user), every slot busy, or a chunk under `MIN_BYTES`: the
arrays go through Dask as before. The client copies the arrays out (`read`: its results
are ordinary numpy arrays of its own, as serial runs give) and marks the slot free for the
next chunk. The file holds numbers only: nothing in it is unpickled or run.

This module is the client's side and the slot's file (its layout, and how a process
reaches a slot and checks its token); the worker's side is `dmoc.batch.shared_file`.
"""

import fcntl
import math
import os
import secrets
import stat
import threading

import numpy as np

# Chunks whose arrays are smaller travel through Dask: a slot costs a few system calls.
MIN_BYTES = 1 << 20

# Slots one batch borrows: a worker writes a chunk into a slot when Dask asks it for the
# results and the client frees the slot as it receives them, so a few per worker suffice;
# an unused slot is an empty file.
SLOTS = 8

# Bytes of slots the client keeps between batches (the rest are emptied): about what a
# batch of 1000 runs of 1000 knife-edge steps keeps in flight on 2 workers.
KEPT_BYTES = 1 << 26

# A slot's file: its token (16 bytes), its state (8 bytes: FREE, or the ticket of the chunk
# written there and not yet read), then from HEADER on the chunk's arrays.
TOKEN, STATE, HEADER = 16, 8, 64
FREE = bytes(STATE)

_POOL = []                       # the client's free Slots, of the process `_POOL_PID`
_POOL_PID = [os.getpid()]        # (a process forked from the client makes a pool of its own)
_POOL_LOCK = threading.Lock()


class Slot:
    """A file of shared memory of the client's process (memfd): its descriptor `fd` and the
    random `token` written at its start."""

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
    (pid, ((fd, token), ...), MIN_BYTES) a worker's `SharedFile` takes, or None where this
    system has no memfd or no /proc; on exit the slots are freed, whatever was left in them,
    and go back to the pool (`KEPT_BYTES`)."""

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
    """A descriptor of ``/proc/<pid>/fd/<fd>``, checked to be a regular file of this user
    before it is opened at all, or None."""
    path = f"/proc/{pid}/fd/{fd}"
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_uid != os.getuid():
            return None
        return os.open(path, os.O_RDWR | os.O_CLOEXEC | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError:
        return None


def holds_token(handle, token):
    """Whether the open file `handle` is a regular file of this user that starts with
    `token`."""
    info = os.fstat(handle)
    return (stat.S_ISREG(info.st_mode) and info.st_uid == os.getuid()
            and os.pread(handle, TOKEN, 0) == token)


def read(path, layout):
    """The arrays a `SharedFile` put in the slot `path` = (pid, fd, token, ticket), copied
    out into one new buffer of this process, of which they are views (one allocation and
    one read per chunk: numpy backs a large buffer with huge pages, so the copy faults in
    far fewer pages than one array per field); the slot is then free. Raises OSError when
    the slot is not the client's of this token, does not hold this ticket, or is too small
    for the layout, or when the layout places anything but arrays of numbers."""
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
