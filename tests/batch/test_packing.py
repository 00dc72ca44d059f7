"""A chunk of simulate_many's results travels as a few arrays (dmoc.batch.packing) and
arrives as the results the serial runs give (the oracle: `dmoc.simulate` in this
process), field by field and bit for bit: mixed step counts and variants, Newton failures
with their partial trajectories, items that raised (no trajectory), final knots only."""

import os
import pickle

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.batch import item_guard, tasks  # noqa: E402
from dmoc.batch.packing import PackedResults  # noqa: E402
from dmoc.simulation.time_stepping import SimulationResult  # noqa: E402

FIELDS = ("t", "q", "p", "lam", "u", "s", "mu")


def _runs(count):
    """Runs of 3 to 40 steps, both variants, some controlled; every 17th fails Newton's
    tolerance (a partial trajectory), every 29th has a `q0` of the wrong size (raises).
    All in CasADi's virtual machine (`jit=False`): with the default, a loaded machine
    compiles the step in one process and not in the other (`stats["native"]` differs)."""
    runs = []
    for i in range(count):
        steps = 3 + (7 * i) % 38
        run = {"q0": [0, 0, 0.01 * i], "v0": [np.cos(0.01 * i), np.sin(0.01 * i), 1.0],
               "steps": steps, "variant": "+-"[i % 2], "jit": False}
        if i % 3 == 0:
            run["controls"] = np.full((steps, 2), 0.1 * (i % 5))
        if i % 17 == 16:
            run["tol"] = 1e-300
        if i % 29 == 28:
            run["q0"] = [0, 0]
        runs.append(run)
    return runs


def _serial(disc, run, keep):
    try:
        result = dmoc.simulate(disc, **run, throw=False)
    except ValueError as err:
        return None, err
    if keep == "final":
        result.trajectory = tasks.final_knot(result.trajectory)
    return result, None


def _assert_same(got, disc, run, keep):
    want, error = _serial(disc, run, keep)
    if error is not None:
        assert got.status == "exception" and got.trajectory is None and str(error) in got.message
        return
    assert (got.success, got.status, got.message) == (want.success, want.status, want.message)
    assert {k: v for k, v in got.stats.items() if k not in ("wall_time", "worker")} == \
        {k: v for k, v in want.stats.items() if k != "wall_time"}
    for name in FIELDS:
        a, b = getattr(got.trajectory, name), getattr(want.trajectory, name)
        assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    for name in ("h", "variant", "control_nodes", "stage_nodes"):
        assert getattr(got.trajectory, name) == getattr(want.trajectory, name), name


def _in_process(disc, runs, keep):
    """What a worker's task makes of `runs` (results of `simulate` or of an exception)."""
    results = []
    for run in runs:
        want, error = _serial(disc, run, keep)
        results.append(want if error is None else item_guard.failed_result(
            SimulationResult, "exception", f"{type(error).__name__}: {error}"))
    return results


@pytest.mark.parametrize("keep", ["trajectory", "final"])
def test_a_packed_chunk_unpickles_as_the_serial_results_from_a_few_buffers(keep):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = _runs(60)
    buffers = []
    data = pickle.dumps(PackedResults(_in_process(disc, runs, keep)), protocol=5,
                        buffer_callback=buffers.append)
    assert len(buffers) <= len(FIELDS)           # not 7 per run
    results = pickle.loads(data, buffers=buffers)
    assert type(results) is list and len(results) == len(runs)
    for got, run in zip(results, runs):
        _assert_same(got, disc, run, keep)
    trajectories = [r.trajectory for r in results if r.trajectory is not None]
    for a, b in zip(trajectories, trajectories[1:]):       # each run's rows are its own
        assert not any(np.shares_memory(getattr(a, f), getattr(b, f)) for f in FIELDS)


def test_trajectories_of_other_columns_travel_whole():
    """A chunk of runs whose trajectories have other columns (not made by simulate_many,
    whose chunks share one discretization) still round-trips."""
    knife = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    disk = dmoc.discretize(dmoc.systems.rolling_disk(), 0.05)
    results = [dmoc.simulate(knife, q0=[0, 0, 0], v0=[1, 0, 1], steps=4),
               dmoc.simulate(disk, q0=[0, 0, 0, 0], v0=[1, 0, 1, 0.5], steps=6)]
    back = pickle.loads(pickle.dumps(PackedResults(results)))
    for got, want in zip(back, results):
        for name in FIELDS:
            assert getattr(got.trajectory, name).tobytes() == getattr(want.trajectory, name).tobytes()


@pytest.mark.parametrize("keep", ["trajectory", "final"])
def test_simulate_many_with_mixed_steps_and_failures_in_its_chunks_equals_serial(client, keep):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = _runs(150)
    with distributed.get_task_stream(client=client) as stream:
        results = batch.simulate_many(disc, runs, keep=keep, client=client, progress=False)
    assert len(stream.data) <= len(runs) // 4           # chunks of several runs
    for got, run in zip(results, runs):
        _assert_same(got, disc, run, keep)
    assert sum(r.status == "newton_failed" for r in results) == 8
    assert sum(r.status == "exception" for r in results) == 5


@pytest.mark.parametrize("keep", ["trajectory", "final"])
def test_trajectories_through_shared_memory_equal_serial_and_free_their_slots(
        client, keep, monkeypatch):
    """With every chunk large enough (MIN_BYTES = 0) the workers of this machine write the
    arrays into the slots of the client's pool: the results are the serial ones bit for
    bit, in arrays the client owns (writable, no run sees another's change), and every
    slot is free after the batch."""
    from dmoc.batch import shared_memory
    if not hasattr(os, "memfd_create"):
        pytest.skip("no memfd here: every chunk goes through Dask")
    monkeypatch.setattr(shared_memory, "MIN_BYTES", 0)
    chunks = []
    read = shared_memory.read
    monkeypatch.setattr(shared_memory, "read",
                        lambda path, layout: chunks.append(path) or read(path, layout))
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = _runs(150)
    results = batch.simulate_many(disc, runs, keep=keep, client=client, progress=False)
    for got, run in zip(results, runs):
        _assert_same(got, disc, run, keep)
    assert len(chunks) >= 2 and {path[0] for path in chunks} == {os.getpid()}
    shared = [r.trajectory for r in results if r.trajectory is not None]
    shared[0].q[...] = 7.0                       # writable, and no other run sees it
    assert not any((t.q == 7.0).all() for t in shared[1:])
    states = {os.pread(slot.fd, shared_memory.STATE, shared_memory.TOKEN) for slot in shared_memory._POOL}
    assert states == {shared_memory.FREE}


def _pendulum():
    """L = v^2/2 + cos q, f = 0.4 v^2 + u: a kick u = 20 needs the line-search Newton, a
    kick u = 300 leaves the midpoint step without a real solution."""
    import casadi as ca
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2 + ca.cos(q[0]), 1,
                                 force=lambda q, v, u: 0.4 * v[0] ** 2 + u[0], n_u=1)


def _kicked_runs(count, steps=30):
    runs = []
    for i in range(count):
        controls = np.full((steps, 1), 0.01 * i)
        controls[(3 * i) % steps] = (0.0, 20.0, 300.0)[i % 3]
        runs.append({"q0": [0.1 * i], "v0": [1.0], "steps": steps, "controls": controls,
                     "variant": "+-"[i % 2]})
    return runs


def _raise(*args, **kwargs):
    from dmoc.simulation import lockstep
    lockstep.raised += 1
    raise RuntimeError("lockstep broke")


def _break_lockstep(broken):
    """In a worker: make `run_lockstep` raise (counting in `lockstep.raised`), or restore
    it; returns how often it raised."""
    from dmoc.simulation import lockstep
    if broken:
        lockstep.saved, lockstep.run_lockstep, lockstep.raised = lockstep.run_lockstep, _raise, 0
        return 0
    lockstep.run_lockstep = lockstep.saved
    return lockstep.raised


@pytest.mark.parametrize("how, keep", [("lockstep", "trajectory"), ("timeout", "trajectory"),
                                       ("lockstep raises", "trajectory"),
                                       ("lockstep raises", "final")])
def test_runs_in_lockstep_on_the_workers_equal_serial_runs(client, how, keep):
    """A worker steps a chunk's runs in lockstep (no `timeout`), one by one with a
    `timeout`, and one by one again when the lockstep raises (then cut to the last knot
    with `keep="final"`): the results are the serial ones every time, redone steps and
    failures included."""
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = _kicked_runs(60)
    if how == "lockstep raises":
        client.run(_break_lockstep, True)
    try:
        results = batch.simulate_many(disc, runs, keep=keep, client=client, progress=False,
                                      timeout=60 if how == "timeout" else None)
    finally:
        if how == "lockstep raises":
            assert sum(client.run(_break_lockstep, False).values()) >= 1     # a chunk of several runs
    for got, run in zip(results, runs):
        _assert_same(got, disc, run, keep)
    statuses = {r.status for r in results}
    assert statuses == {"converged", "newton_failed"}
    assert any(r.success and r.stats["robust_steps"] for r in results)


def _calls(disc, runs):
    """(load, solve) pairs of `tasks.simulate_chunk` for `runs`, already unpickled."""
    return [((lambda run=run: (disc, run)), lambda loaded: dmoc.simulate(loaded[0], **loaded[1],
                                                                          throw=False))
            for run in runs]


@pytest.mark.parametrize("keep", ["trajectory", "final"])
def test_a_chunk_ends_once_it_has_spent_its_budget(keep, monkeypatch):
    """A chunk with a CPU budget runs its first run alone and stops when the budget is
    spent (in lockstep, and one by one with a `timeout`); without one, or with enough,
    it runs them all; what it returns are the serial results."""
    for module in (tasks, item_guard):
        monkeypatch.setattr(module, "stamp", lambda results: None)     # no worker here
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = _runs(40)
    final = keep == "final"
    for budget, count in ((1e-9, 1), (None, 40), (1e3, 40)):
        results, seconds = tasks._in_budget(_calls(disc, runs), final, budget)
        assert len(results) == len(seconds) == count
        for got, run in zip(results, runs):
            _assert_same(got, disc, run, keep)
        results, seconds = item_guard.guarded_chunk(SimulationResult, _calls(disc, runs), 60, budget)
        assert len(results) == len(seconds) == count


@pytest.mark.parametrize("keep", ["trajectory", "final"])
def test_runs_a_budget_left_unrun_are_queued_again_and_run_once(client, keep, monkeypatch):
    """Before a cost is measured the client sends chunks with a budget (`ChunkSizes.budget`,
    TARGET): with a budget smaller than any run, the first chunks return one result each,
    the client queues their other runs again, and every run gets its serial result."""
    from dmoc.batch import chunk_sizes as chunks
    monkeypatch.setattr(chunks, "TARGET", 1e-9)
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = _runs(30)
    with distributed.get_task_stream(client=client) as stream:
        results = batch.simulate_many(disc, runs, keep=keep, client=client, progress=False)
    assert len(stream.data) == len(runs)        # every chunk returned after one run
    for got, run in zip(results, runs):
        _assert_same(got, disc, run, keep)


@pytest.mark.skipif(not hasattr(os, "memfd_create") or not os.path.isdir("/proc/self/fd"),
                    reason="no memfd or /proc here: every chunk goes through Dask")
def test_a_chunk_in_lockstep_writes_its_trajectories_straight_into_the_slot(monkeypatch):
    """A worker's chunk stepped in lockstep copies each run's trajectory once, from the
    lockstep's memory straight into a slot of the client's shared memory (`ChunkMemory`):
    when the chunk is pickled every array is in the slot already and nothing more is
    written there; pickled twice it names the same slot, which the client reads once, and
    the results are the serial ones bit for bit."""
    from dmoc.batch import shared_memory, shipping
    monkeypatch.setattr(tasks, "stamp", lambda results: None)           # no worker here
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 30, "jit": False}
            for c in np.linspace(0.5, 2, 12)]
    shipments, items = shipping.run_items([disc] * len(runs), runs)
    (digest, data), = shipments.items()
    shipment = tasks.Shipment(digest, data)
    shipment.setup(None)
    try:
        with shared_memory.Exchange() as share:
            packed, _ = tasks.simulate_chunk(digest, [bytes(d) for _, d in items], None,
                                             share=(*share[:2], 0))
            memory = packed.memory
            assert memory.file.held and len(packed) == len(runs)
            for result in packed:
                for name in FIELDS:
                    a = getattr(result.trajectory, name)
                    assert a.size == 0 or memory.position(a) is not None, name
            used = memory.used
            sent = pickle.dumps(packed, protocol=5)
            assert memory.used == used and not memory.file.held     # nothing copied: sealed
            assert pickle.dumps(packed, protocol=5) == sent          # the same slot again
            results = pickle.loads(sent)
    finally:
        shipment.teardown(None)
    for got, run in zip(results, runs):
        _assert_same(got, disc, run, "trajectory")
