"""dmoc.batch on a scheduler and workers started as separate processes (``dask scheduler``
and ``dask worker`` on 127.0.0.1, over TCP), reached by address, by a kept `Cluster` and
by Dask's configured address: the results equal the serial in-process `dmoc.optimize` /
`dmoc.simulate` (the oracle), and a kept cluster keeps each worker's solver across calls.
Every wait is bounded; the processes are stopped by their own ids at the end."""

import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import dask  # noqa: E402

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402

ROOT = pathlib.Path(__file__).parents[2]
START_TIMEOUT = 90       # seconds for the scheduler to write its address and the workers to join


def _dask(*arguments, log):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "dask", *arguments], env=env,
                            stdout=log, stderr=subprocess.STDOUT)


@pytest.fixture(scope="module")
def address(tmp_path_factory):
    """The TCP address of a `dask scheduler` process with two single-threaded workers of
    one `dask worker` process (its nanny)."""
    folder = tmp_path_factory.mktemp("remote")
    file = folder / "scheduler.json"
    processes = []
    with open(folder / "log.txt", "w") as log:
        try:
            processes.append(_dask("scheduler", "--host", "127.0.0.1", "--port", "0",
                                   "--dashboard-address", ":0", "--scheduler-file", str(file), log=log))
            deadline = time.monotonic() + START_TIMEOUT
            while not file.exists() and time.monotonic() < deadline:
                time.sleep(0.2)
            assert file.exists(), (folder / "log.txt").read_text()[-3000:]
            processes.append(_dask("worker", "--scheduler-file", str(file), "--nworkers", "2",
                                   "--nthreads", "1", "--host", "127.0.0.1",
                                   "--no-dashboard", log=log))
            address = json.loads(file.read_text())["address"]
            with distributed.Client(address, timeout=START_TIMEOUT) as client:
                client.wait_for_workers(2, timeout=START_TIMEOUT)
            yield address
        finally:
            for process in reversed(processes):
                process.terminate()
            for process in reversed(processes):
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait(timeout=30)


def _assert_same_as_serial(problems, results):
    assert len(results) == len(problems)
    for problem, got in zip(problems, results):
        want = dmoc.optimize(problem)
        assert got.success and abs(got.cost - want.cost) <= 1e-10
        assert np.abs(got.trajectory.q - want.trajectory.q).max() <= 1e-10


def test_remote_workers_give_the_serial_results(address):
    base = knife_edge_parking(20)
    problems = [base.with_boundary(q_goal=[0.0, y, 0.1]) for y in np.linspace(0.2, 2.0, 24)]
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 200} for c in np.linspace(0.5, 2.0, 12)]
    with batch.Cluster(address) as cluster:
        workers = set(cluster.client.scheduler_info()["workers"])
        results = batch.optimize_many(problems, client=cluster, progress=False)
        sims = batch.simulate_many(disc, runs, client=cluster, progress=False)
    _assert_same_as_serial(problems, results)
    assert {r.stats["worker"] for r in results} == workers and len(workers) == 2
    for got, run in zip(sims, runs):
        want = dmoc.simulate(disc, **run).trajectory
        assert got.success and np.array_equal(got.trajectory.q, want.q)
        assert np.array_equal(got.trajectory.p, want.p)
    by_address = batch.optimize_many(problems[:3], client=address, progress=False)
    _assert_same_as_serial(problems[:3], by_address)
    with distributed.Client(address, timeout=START_TIMEOUT) as client:   # still running
        assert len(client.scheduler_info()["workers"]) == 2
        assert client.run_on_scheduler(_dmoc_plugins) == []            # shipments taken back


def _dmoc_plugins(dask_scheduler):
    return sorted(name for name in dask_scheduler.worker_plugins if name.startswith("dmoc"))


def test_the_configured_scheduler_address_is_the_default(address):
    """``DASK_SCHEDULER_ADDRESS`` (Dask's "scheduler-address") replaces the LocalCluster: the
    same script runs on any cluster that sets it."""
    problems = [knife_edge_parking(20, goal=[0.0, y, 0.0]) for y in (0.5, 1.0)]
    with dask.config.set({"scheduler-address": address}):
        results = batch.optimize_many(problems, progress=False)
        with batch.Cluster() as cluster:
            assert cluster.client.scheduler.address == address
    with distributed.Client(address, timeout=START_TIMEOUT) as client:
        assert {r.stats["worker"] for r in results} <= set(client.scheduler_info()["workers"])
    _assert_same_as_serial(problems, results)


def test_a_kept_cluster_keeps_each_workers_solver_across_calls():
    base = knife_edge_parking(20)
    problems = [base.with_boundary(q_goal=[0.0, y, 0.1]) for y in np.linspace(0.2, 2.0, 8)]
    with batch.Cluster(workers=2) as cluster:
        first = batch.optimize_many(problems, client=cluster, progress=False)
        workers = {r.stats["worker"] for r in first}
        assert len(workers) == 2
        cluster.client.run(_fresh_problems_only)       # the workers drop the unpacked problem
        second = batch.optimize_many(problems, client=cluster.client, progress=False)
    assert cluster.client.status == "closed"
    assert all(r.stats["solver_reused"] for r in second)
    assert {r.stats["worker"] for r in second} <= workers
    _assert_same_as_serial(problems, first)
    _assert_same_as_serial(problems, second)


def test_a_clusters_workers_run_without_dasks_malloc_trimming_and_profiler(monkeypatch):
    """Dask's nannies set MALLOC_TRIM_THRESHOLD_=65536 in the workers they spawn (and in
    the spawning process), which makes each solve about 1.3x slower, and its workers sample
    their threads every 10 ms; a dmoc Cluster's workers do neither."""
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)   # put by other clusters
    assert dask.config.get("distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_")
    assert dask.config.get("distributed.worker.profile.enabled")
    with batch.Cluster(workers=1) as cluster:
        seen = cluster.client.run(lambda: (os.environ.get("MALLOC_TRIM_THRESHOLD_"),
                                           dask.config.get("distributed.worker.profile.enabled")))
    assert list(seen.values()) == [(None, False)]
    assert "MALLOC_TRIM_THRESHOLD_" not in os.environ


def _fresh_problems_only():
    from dmoc.batch import tasks
    tasks._LOADED.clear()


@pytest.mark.parametrize("args, kwargs, error, words", [
    (("tcp://127.0.0.1:1",), {"workers": 2}, dmoc.InputError, "`workers` starts a LocalCluster"),
    ((), {"workers": 0}, dmoc.InputError, "`workers` must be a positive integer; got 0"),
    ((8786,), {}, dmoc.InputTypeError, "`address` must be a scheduler address .* got int"),
    (("tcp://127.0.0.1:1",), {"connect_timeout": -1}, dmoc.InputError, "`connect_timeout`"),
])
def test_a_cluster_checks_its_arguments_before_starting_anything(args, kwargs, error, words):
    with pytest.raises(error, match=words):
        batch.Cluster(*args, **kwargs)
