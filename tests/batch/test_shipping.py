"""What a batch sends: one shipment per problem that the others cannot be rebuilt from
(oracle: the problems' own bounds, p and step, compared here), items as data, and chunks
of several items; the results equal the serial in-process solves and runs (the oracle),
and a worker that keeps dying confines its loss to the one item that kills it."""

import os
import signal
from concurrent.futures import ThreadPoolExecutor

import casadi as ca
import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.batch import shipping  # noqa: E402
from dmoc.batch.chunk_sizes import ChunkSizes  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402


def _weighted(r):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    return dmoc.OptimalControlProblem(disc, 20, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                      parameters={"r": r},
                                      running_cost=lambda q, v, u, w: u[0] ** 2 + w["r"] * u[1] ** 2)


def _mixed_problems():
    """(problems, the number of shipments they need): with_boundary copies of one base and
    problems built alike travel as data; other bounds, another step h, and another
    structure are shipped themselves."""
    base = knife_edge_parking(20)
    moved = [base.with_boundary(q_goal=[0.0, y, 0.1]) for y in (0.5, 1.0, 1.5)]
    built_alike = knife_edge_parking(20, goal=[0.3, 0.8, 0.0])
    bounded = dmoc.OptimalControlProblem(base.disc, 20, q_start=base.q_start, q_goal=[0, 1, 0],
                                         control_bounds=([-2, -2], [2, 2]))
    finer = dmoc.OptimalControlProblem(dmoc.discretize(base.disc.system, base.disc.h / 2), 20,
                                       q_start=base.q_start, q_goal=[0, 1, 0])
    moving_goal = base.with_boundary(v_goal=[None, None, None])      # velocity rows appear
    weighted = _weighted(1.0)
    problems = [*moved, built_alike, bounded, finer, moving_goal, weighted,
                weighted.with_parameters(r=10.0), _weighted(3.0)]
    return problems, 5


def test_problems_travel_as_data_when_one_shipped_rebuilds_them():
    problems, shipments_needed = _mixed_problems()
    assert problems[4].structure == problems[0].structure       # same NLP, other bounds
    assert problems[5].structure == problems[0].structure       # same NLP, other h
    shipments, items = shipping.problem_items(problems, [None] * len(problems))
    assert len(shipments) == shipments_needed
    names = [name for name, _ in items]
    assert len({names[0], names[1], names[2], names[3]}) == 1
    assert len({names[0], names[4], names[5], names[6], names[7]}) == 5
    assert names[7] == names[8] == names[9]
    for packed in shipments.values():       # each shipment is a whole problem
        assert isinstance(batch.unpack_problem(packed), dmoc.OptimalControlProblem)


def test_mixed_problems_match_serial_solves(client):
    problems, _ = _mixed_problems()
    results = batch.optimize_many(problems, client=client, progress=False)
    for problem, got in zip(problems, results):
        want = dmoc.optimize(problem)
        assert got.success and abs(got.cost - want.cost) <= 1e-10 * max(1.0, want.cost)
        assert np.abs(got.trajectory.q - want.trajectory.q).max() <= 1e-10
        assert np.array_equal(got.trajectory.h, want.trajectory.h)
    assert results[8].cost > results[7].cost        # the heavier weight costs more


def test_many_cheap_runs_go_in_chunks_and_match_serial_runs(client):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 5} for c in np.linspace(0.1, 2.0, 200)]
    with distributed.get_task_stream(client=client) as stream:
        results = batch.simulate_many(disc, runs, client=client, progress=False)
    assert len(stream.data) <= len(runs) // 4           # at most 50 tasks for 200 runs
    for got, run in zip(results, runs):
        assert np.array_equal(got.trajectory.q, dmoc.simulate(disc, **run).trajectory.q)


def _kill_always():
    """A value whose unpickling SIGKILLs any process but this one."""
    here = os.getpid()

    def fire():
        if os.getpid() != here:
            os.kill(os.getpid(), signal.SIGKILL)
        return Killer()

    class Killer:
        def __reduce__(self):
            return fire, ()

    return Killer()


def test_an_item_that_kills_its_chunks_workers_is_the_only_one_lost():
    """With no failure allowed, a chunk whose worker dies comes back as KilledWorker; its
    items are run again one per chunk, so only the killer is "worker_lost"."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 5} for c in np.linspace(0.1, 2.0, 400)]
    runs[200] = {**runs[200], "controls": _kill_always()}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0",
                                  scheduler_kwargs={"allowed_failures": 0}) as cluster, \
            distributed.Client(cluster) as client:
        with distributed.get_task_stream(client=client) as stream:
            results = batch.simulate_many(disc, runs, client=client, progress=False)
    # fewer tasks than runs: the items of the chunk that lost its worker run again one per
    # task (with two chunks per worker thread, up to a quarter of the runs), the others in chunks
    assert len(stream.data) < len(runs)
    failed = {i: (r.status, r.message) for i, r in enumerate(results) if not r.success}
    assert list(failed) == [200], failed
    assert results[200].status == "worker_lost" and "KilledWorker" in results[200].message
    for got, run in zip(results[:200] + results[201:], runs[:200] + runs[201:]):
        assert np.array_equal(got.trajectory.q, dmoc.simulate(disc, **run).trajectory.q)


@pytest.mark.parametrize("seconds, queued, threads, size", [
    ([], 1000, 2, 250),                               # nothing measured yet: a thread's share
    ([0.004, 0.005, 0.006], 1000, 2, 100),            # 0.5 s / 5 ms
    ([0.004, 0.005, 0.006], 80, 2, 20),               # 80 / (2 chunks x 2 threads)
    ([0.004, 0.005, 0.006], 40, 2, 10),               # the tail: at least 0.05 s a chunk
    ([0.6], 1000, 2, 1),                              # slower than the target
    ([0.5, 0.01, 0.01], 1000, 8, 50),                 # the median, not the first solve
    ([0.001], 20, 2, 50),                             # the tail: at least 0.05 s a chunk
    ([0.001], 2000, 64, 50),                          # many threads: the same floor
])
def test_chunk_size_aims_at_half_a_second_and_leaves_work_for_every_thread(
        seconds, queued, threads, size):
    sizes = ChunkSizes()
    sizes.measured(seconds)
    assert sizes.next(queued, threads) == size


def test_progress_shows_elapsed_time_and_eta():
    import io

    from dmoc.batch.progress import ProgressBar
    ticks, stream = iter([100.0, 100.0, 130.0, 190.0]), io.StringIO()
    bar = ProgressBar(8, "simulate", stream, clock=lambda: next(ticks), terminal=True)
    bar.advance(2)          # 30 s for 2 of 8: 90 s to go
    bar.advance(6)
    bar.close()
    frames = stream.getvalue().split("\r")
    assert frames[2] == "simulate [#######.......................] 2/8 elapsed 0:30 eta 1:30"
    assert frames[3] == "simulate [##############################] 8/8 elapsed 1:30 eta 0:00\n"
    assert frames[1].endswith("0/8 elapsed 0:00 eta ?")


def test_progress_in_a_log_is_one_plain_line_per_tenth():
    """A stream that is not a terminal (a StringIO, as a CI log) gets no carriage returns:
    a line at the first item and at each further tenth of 1000 items, 11 in all, however
    the items arrive; a bar closed early ends with its state."""
    import io

    from dmoc.batch.progress import ProgressBar
    stream = io.StringIO()
    bar = ProgressBar(1000, "optimize", stream, clock=lambda: 0.0)
    for _ in range(1000):
        bar.advance(1)
    bar.close()
    lines = stream.getvalue().split("\n")
    assert "\r" not in stream.getvalue() and lines[-1] == ""
    assert [line.split()[2] for line in lines[:-1]] == ["1/1000"] + [f"{100 * k}/1000" for k in range(1, 11)]
    stream = io.StringIO()
    bar = ProgressBar(1000, "optimize", stream, clock=lambda: 0.0)
    bar.advance(150)
    bar.advance(3)
    bar.close()
    assert [line.split()[2] for line in stream.getvalue().splitlines()] == ["150/1000", "153/1000"]


def test_a_problem_whose_rebuild_is_refused_is_shipped_itself():
    """A goal outside the first problem's state bounds cannot come from its with_boundary
    (it raises): that problem is shipped on its own. (The goals are mirror images, so the
    NLPs' scales, which follow the length of the motion, and so the structures agree.)"""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    narrow = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                        state_bounds=([-1, -0.5, -ca.inf], [1, 1.5, ca.inf]))
    wide = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, -1, 0],
                                      state_bounds=([-5, -5, -ca.inf], [5, 5, ca.inf]))
    assert narrow.structure == wide.structure
    shipments, items = shipping.problem_items([narrow, wide], [None, None])
    assert len(shipments) == 2 and items[0][0] != items[1][0]


def _shipped_bytes():
    from dmoc.batch import tasks
    return len(tasks._SHIPPED)


def _dmoc_plugins(dask_scheduler):
    return sorted(name for name in dask_scheduler.worker_plugins if name.startswith("dmoc"))


def test_a_batch_takes_its_shipments_back(client):
    """After the call no worker holds the shipped bytes and the scheduler no plugin, also
    when the same bytes were shipped twice at once (two calls from two threads)."""
    problems = [knife_edge_parking(20).with_boundary(q_goal=[0.0, y, 0.1]) for y in (0.5, 1.0)]
    with ThreadPoolExecutor(2) as pool:
        calls = [pool.submit(batch.optimize_many, problems, client=client, progress=False)
                 for _ in range(2)]
        first, second = (call.result(timeout=120) for call in calls)
    assert [r.cost for r in first] == [r.cost for r in second]
    assert all(r.success for r in first)
    assert set(client.run(_shipped_bytes).values()) == {0}
    assert client.run_on_scheduler(_dmoc_plugins) == []


def test_plain_data_is_pickled_plainly_and_anything_else_by_cloudpickle():
    """A run of numbers, strings and numpy arrays is written by plain pickle (faster),
    which gives the same object as cloudpickle; a local class, a function or a cyclic
    list is not plain and goes through cloudpickle, which pickles them by value."""
    import pickle

    import cloudpickle

    class Local:
        pass

    run = {"q0": [0, 0.5, np.float64(1.0)], "v0": np.array([1.0, 0.0, 1.0]), "steps": 3,
           "variant": "-", "controls": np.zeros((3, 2)), "jit": None, "tol": (1e-12,)}
    assert shipping.plain(run) and shipping.pickled("run", run) == pickle.dumps(run, protocol=5)
    back = pickle.loads(shipping.pickled("run", run))
    assert back.keys() == run.keys() and back["v0"].tobytes() == run["v0"].tobytes()
    assert pickle.loads(cloudpickle.dumps(run))["q0"] == back["q0"]
    cyclic = []
    cyclic.append(cyclic)
    for other in ({"force": lambda u: u}, {"x": Local()}, cyclic, {1: 2.0},
                  np.array(["a"]), np.array([None]), np.ma.array([1.0])):
        assert not shipping.plain(other)

    class Number(float):
        pass

    scalars = [np.bool_(True), np.int8(1), np.uint64(2), np.float32(0.5), np.complex64(1j)]
    for scalar in scalars:                # alone, in a list, as a dict's value
        assert shipping.plain(scalar) and shipping.plain([scalar]) and shipping.plain({"x": scalar})
    for other in (Number(1.0), np.datetime64("2026-01-01"), np.str_("a"), [[[[[[[[[1]]]]]]]]]):
        assert not shipping.plain(other) and not shipping.plain([other]) and not shipping.plain({"x": other})
    assert pickle.loads(shipping.pickled("run", {"force": lambda u: 2 * u}))["force"](3) == 6


def test_the_chunks_of_one_fill_go_to_the_scheduler_in_one_message():
    """`Batch._fill` submits the chunks it fills in one `Client.map` call (one message:
    the client holds back a message sent within 10 ms of the previous one, so chunks
    submitted one by one reach the second worker later): consecutive items, each chunk
    of one shipment, the item bytes as `shipping.item` makes them, its own key."""
    from dmoc.batch import scheduling

    class Client:
        calls = []

        def map(self, task, *iterables, **keywords):
            self.calls.append((task, iterables, keywords))
            return [object() for _ in iterables[0]]

    runs = [{"q0": [0.0, 0.0, float(i)], "steps": 5} for i in range(24)]
    items = [("a" if i < 8 else "b", shipping.item(f"runs[{i}]", run)) for i, run in enumerate(runs)]
    fill = scheduling.Batch(Client(), len, ("argument",), items, None, "simulate")
    fill._fill(2)
    [(task, (digests, data, arguments), keywords)] = Client.calls
    chunks = list(fill.flying.values())
    assert task is len and len(chunks) == scheduling.CHUNKS_PER_THREAD * 2
    assert [i for chunk in chunks for i in chunk] == list(range(sum(map(len, chunks))))
    assert digests == [items[chunk[0]][0] for chunk in chunks]
    assert all({items[i][0] for i in chunk} == {digest} for chunk, digest in zip(chunks, digests))
    assert digests == ["a", "a", "b", "b"]                  # a chunk ends with its shipment
    assert data == [[shipping.pickled("run", runs[i]) for i in chunk] for chunk in chunks]
    assert list(arguments) == ["argument"] * len(chunks)
    assert keywords["budget"] == ChunkSizes().budget and keywords["pure"] is False
    assert len(set(keywords["key"])) == len(chunks)
    fill._fill(2)                                       # as many in flight as allowed
    assert len(Client.calls) == 1


def test_problems_built_one_by_one_share_a_shipment_and_a_solver_per_worker_and_structure(client):
    """Problems built as a user writes them, each with its own Discretization object: one
    shipment per NLP `structure` (the oracle: the structures counted here), and each
    worker builds the solver of a structure at most once; the costs are the serial ones."""
    problems = [dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), 0.2), 20,
                                           q_start=[0, 0, 0], q_goal=[0.0, y, 0.1])
                for y in np.linspace(0.2, 2.0, 40)]
    structures = {p.structure for p in problems}
    shipments, items = shipping.problem_items(problems, [None] * len(problems))
    assert len(shipments) == len(structures) < len(problems)
    results = batch.optimize_many(problems, client=client, progress=False)
    built = [(r.stats["worker"], r.structure) for r in results if not r.stats["solver_reused"]]
    assert len(built) == len(set(built)) <= 2 * len(structures)
    for problem, got in zip(problems, results):
        assert got.success and abs(got.cost - dmoc.optimize(problem).cost) <= 1e-10


def test_discretizations_built_one_by_one_are_shipped_once():
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 5} for c in (0.5, 1.0, 1.5)]
    discs = [dmoc.discretize(dmoc.systems.knife_edge(), 0.05) for _ in runs]
    other = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    shipments, items = shipping.run_items([*discs, other], [*runs, runs[0]])
    assert len(shipments) == 2
    assert items[0][0] == items[1][0] == items[2][0] != items[3][0]
