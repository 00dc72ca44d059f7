"""The shared-memory exchange of simulate_many's packed arrays (dmoc.batch.shared_memory,
the client's side and the worker's): what a worker writes into a slot
of the client's pool the client reads back bit for bit, into arrays of its own, and the
slot is free again; a slot that is not the client's, not of this chunk or too small is
refused; busy slots, small chunks and full memory go through Dask; whatever a batch leaves
in its slots is freed at its end, and the pool keeps at most KEPT_BYTES."""

import gc
import os

import numpy as np
import pytest

pytest.importorskip("distributed")

from dmoc.batch import shared_memory, slot_writer  # noqa: E402

if not hasattr(os, "memfd_create") or not os.path.isdir("/proc/self/fd"):
    pytest.skip("no memfd or /proc here: every chunk goes through Dask", allow_module_level=True)


@pytest.fixture(autouse=True)
def empty_pool():
    """Each test starts with no slot in the pool, as a new client process."""
    for slot in shared_memory._POOL:
        os.close(slot.fd)
    shared_memory._POOL.clear()


def _arrays(rows=7):
    rng = np.random.default_rng(rows)
    return {"t": rng.random(rows), "q": rng.random((rows, 3)), "lam": rng.random((rows - 1, 0)),
            "mu": rng.random((2, 1))}


def _write(share, rows=7):
    """What a worker does with a chunk's arrays: (path, layout), or None (through Dask)."""
    file, arrays, layout, size = slot_writer.SharedFile(share), _arrays(rows), {}, 0
    for name, a in arrays.items():
        layout[name], size = (size, a.dtype.str, a.shape), size + a.nbytes
    memory = file.reserve(size)
    if memory is None:
        return None
    for name, a in arrays.items():
        start = shared_memory.HEADER + layout[name][0]
        np.frombuffer(memory, a.dtype, a.size, start).reshape(a.shape)[...] = a
    return (file.path, file.layout) if file.seal(layout) else None


def _any_size(share):
    """`share` with every chunk large enough for a slot."""
    return (*share[:2], 0)


def _states(slots):
    return [os.pread(slot.fd, shared_memory.STATE, shared_memory.TOKEN) for slot in slots]


def test_what_a_worker_writes_the_client_takes_bit_for_bit_as_arrays_of_its_own():
    """The client's arrays are the slot's pages, mapped privately, not copied: bit for bit
    what the worker wrote, writable, views of one buffer per chunk. Read once, the slot
    takes the next chunk in a new file, which leaves them as they are; the client's
    writes do not reach the file; once the arrays are gone the file is back in the pool,
    free, with what the worker wrote."""
    with shared_memory.Exchange() as share:
        path, layout = _write(_any_size(share))
        inode = os.fstat(path[1]).st_ino
        back = shared_memory.read(path, layout)
        owner = back["t"].base                        # one buffer of the client per chunk
        for name, a in _arrays().items():
            assert back[name].shape == a.shape and back[name].tobytes() == a.tobytes()
            assert back[name].base is owner and back[name].flags.writeable
            assert back[name].flags.aligned and back[name].dtype == a.dtype
        with pytest.raises(OSError, match="not a slot of this batch holding that chunk"):
            shared_memory.read(path, layout)                 # read once
        assert os.fstat(path[1]).st_ino != inode             # a new file under the slot
        assert _write(_any_size(share), rows=9) is not None  # takes the next chunk
        assert all(back[name].tobytes() == a.tobytes() for name, a in _arrays().items())
        back["q"][...] = -1.0
    del back, owner
    gc.collect()
    taken = [slot for slot in shared_memory._POOL if os.fstat(slot.fd).st_ino == inode]
    assert len(taken) == 1 and _states(taken) == [shared_memory.FREE]
    q = _arrays()["q"]
    assert os.pread(taken[0].fd, q.nbytes, shared_memory.HEADER + layout["q"][0]) == q.tobytes()


def test_slots_are_reused_across_batches_and_freed_at_the_end():
    with shared_memory.Exchange() as share:
        first = _write(_any_size(share))[0][:3]
        _write(_any_size(share))                        # never read
        lent = share[1]
    assert set(_states(shared_memory._POOL)) == {shared_memory.FREE}
    with shared_memory.Exchange() as share:
        assert share[1] == lent                          # the pool lends the same slots
        assert _write(_any_size(share))[0][:3] == first  # the first one free again


def test_the_pool_keeps_at_most_kept_bytes(monkeypatch):
    monkeypatch.setattr(shared_memory, "KEPT_BYTES", shared_memory.GRAIN + shared_memory.HEADER)
    with shared_memory.Exchange() as share:
        for _ in range(3):
            _write(_any_size(share), rows=10)
    sizes = [os.fstat(slot.fd).st_size for slot in shared_memory._POOL]
    assert sizes[0] == shared_memory.GRAIN and max(sizes[1:]) <= shared_memory.HEADER


def test_small_chunks_busy_slots_and_no_share_use_dask():
    with shared_memory.Exchange() as share:
        assert _write(share) is None                     # under MIN_BYTES
        assert _write(None) is None
        held = []
        for _ in range(shared_memory.SLOTS):
            file = slot_writer.SharedFile(_any_size(share))
            assert file.reserve(32) is not None
            held.append(file)
        assert _write(_any_size(share)) is None           # every slot is being written
        held[0].release()
        assert _write(_any_size(share)) is not None
        for file in held[1:]:
            file.release()


def test_a_worker_uses_no_slot_that_is_not_the_clients():
    with shared_memory.Exchange() as share:
        pid, slots, _ = share
        wrong_token = tuple((fd, bytes(shared_memory.TOKEN)) for fd, _ in slots)
        assert _write((pid, wrong_token, 0)) is None
        no_such_process = max(int(p) for p in os.listdir("/proc") if p.isdigit()) + 10 ** 6
        assert _write((no_such_process, slots, 0)) is None


def test_the_client_reads_numbers_only():
    with shared_memory.Exchange() as share:
        path, layout = _write(_any_size(share))
        for spoilt in [(0, "|O", (1,)), (-8, "<f8", (1,)), (0, "<f8", (-1, 3))]:
            with pytest.raises(OSError, match="arrays of numbers"):
                shared_memory.read(path, dict(layout, mu=spoilt))
        assert shared_memory.read(path, layout)["mu"].shape == (2, 1)    # the slot kept its chunk


@pytest.mark.parametrize("spoil", ["token", "ticket", "layout"])
def test_the_client_refuses_a_slot_it_cannot_trust(spoil):
    with shared_memory.Exchange() as share:
        (pid, fd, token, ticket), layout = _write(_any_size(share))
        if spoil == "token":
            token = bytes(shared_memory.TOKEN)
        elif spoil == "ticket":
            ticket = bytes(reversed(ticket))
        else:
            layout["mu"] = (layout["mu"][0], "<f8", (1 << 20, 1))
        with pytest.raises(OSError, match="not a slot of this batch holding that chunk"):
            shared_memory.read((pid, fd, token, ticket), layout)


def test_full_memory_means_dask_and_a_free_slot(monkeypatch):
    def full(fd, offset, size):
        raise OSError(28, "No space left on device")
    with shared_memory.Exchange() as share:
        monkeypatch.setattr(os, "posix_fallocate", full)
        assert _write(_any_size(share), rows=100_000) is None
        monkeypatch.undo()
        assert _write(_any_size(share), rows=100_000) is not None     # not left locked


def test_a_slot_a_writer_still_holds_at_the_end_leaves_the_pool():
    exchange = shared_memory.Exchange()
    with exchange as share:
        file = slot_writer.SharedFile(_any_size(share))
        file.reserve(32)
        held = next(slot for slot in exchange.slots if slot.fd == file._held[1][1])
    assert held not in shared_memory._POOL and len(shared_memory._POOL) == shared_memory.SLOTS - 1
    file.release()


def test_no_memfd_means_no_exchange(monkeypatch):
    monkeypatch.delattr(os, "memfd_create")
    with shared_memory.Exchange() as share:
        assert share is None


def test_a_forked_process_lends_slots_of_its_own():
    with shared_memory.Exchange() as share:
        parents = share[1]
    read, write = os.pipe()
    child = os.fork()
    if child == 0:                                     # pragma: no cover - the child
        try:
            with shared_memory.Exchange() as share:
                fresh = not {token for _, token in share[1]} & {token for _, token in parents}
                written = _write(_any_size(share))
                ok = fresh and written is not None and shared_memory.read(*written)["q"].shape == (7, 3)
            os.write(write, b"1" if ok else b"0")
        finally:
            os._exit(0)
    os.close(write)
    assert os.read(read, 1) == b"1"
    os.waitpid(child, 0)
    with shared_memory.Exchange() as share:
        assert share[1] == parents                     # the parent's slots are still its own


def test_the_client_reads_nothing_but_a_regular_file_of_its_user(tmp_path):
    with shared_memory.Exchange() as share:
        (pid, fd, token, ticket), layout = _write(_any_size(share))
        read, write = os.pipe()
        try:
            for other in (read, 10 ** 6):                # a pipe; no such descriptor
                with pytest.raises(OSError, match="not a slot of this batch"):
                    shared_memory.read((pid, other, token, ticket), layout)
        finally:
            os.close(read)
            os.close(write)
        assert shared_memory.read((pid, fd, token, ticket), layout)["q"].shape == (7, 3)
