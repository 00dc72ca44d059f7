"""A batch whose scheduler dies while it runs returns what arrived: a `dask scheduler` and
a `dask worker` process on 127.0.0.1, the scheduler killed (SIGKILL) as soon as the first
results have reached the client; every finished result equals the serial in-process
`dmoc.optimize` (the oracle) and every other item is a failed result of status
"scheduler_lost", within a bounded time. Also the arguments `client` refuses, each with an
error naming it."""

import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.batch import progress  # noqa: E402
from dmoc.errors import InputError, InputTypeError  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402

ROOT = pathlib.Path(__file__).parents[2]
START_TIMEOUT = 90       # seconds for the scheduler to write its address and the workers to join
GUARD = 60               # seconds within which the batch must return after the kill


def _dask(*arguments, log):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "dask", *arguments], env=env,
                            stdout=log, stderr=subprocess.STDOUT)


def _stop(processes):
    for process in reversed(processes):
        if process.poll() is None:
            process.kill()
        process.wait(timeout=30)


def _problems(count):
    """`count` parking problems, each built on its own, as a user writes them."""
    return [dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), 0.2), 20,
                                       q_start=[0, 0, 0], q_goal=[0.0, y, 0.1])
            for y in np.linspace(0.5, 1.5, count)]


def test_a_killed_scheduler_returns_the_finished_results_and_marks_the_others(tmp_path, monkeypatch):
    file, processes = tmp_path / "scheduler.json", []
    with open(tmp_path / "log.txt", "w") as log:
        try:
            processes.append(_dask("scheduler", "--host", "127.0.0.1", "--port", "0",
                                   "--dashboard-address", ":0", "--scheduler-file", str(file),
                                   log=log))
            deadline = time.monotonic() + START_TIMEOUT
            while not file.exists() and time.monotonic() < deadline:
                time.sleep(0.2)
            assert file.exists(), (tmp_path / "log.txt").read_text()[-3000:]
            processes.append(_dask("worker", "--scheduler-file", str(file), "--nworkers", "1",
                                   "--nthreads", "1", "--host", "127.0.0.1", "--no-dashboard",
                                   log=log))
            address = json.loads(file.read_text())["address"]
            with distributed.Client(address, timeout=START_TIMEOUT) as client:
                client.wait_for_workers(1, timeout=START_TIMEOUT)
                advance, killed = progress.ProgressBar.advance, []

                def kill_after_first_results(bar, count=1):
                    advance(bar, count)
                    if bar.done and not killed:
                        processes[0].kill()          # the scheduler, mid-batch
                        killed.append(time.monotonic())
                monkeypatch.setattr(progress.ProgressBar, "advance", kill_after_first_results)
                problems = _problems(60)
                results = batch.optimize_many(problems, client=client, progress=False)
                returned = time.monotonic()
        finally:
            _stop(processes)
    assert killed and returned - killed[0] < GUARD
    assert len(results) == len(problems)
    finished = [i for i, r in enumerate(results) if r.status != "scheduler_lost"]
    lost = [i for i, r in enumerate(results) if r.status == "scheduler_lost"]
    assert finished and lost and len(finished) + len(lost) == len(problems)
    for i in finished:
        want = dmoc.optimize(problems[i])
        assert results[i].success and abs(results[i].cost - want.cost) <= 1e-10
    for i in lost:
        assert not results[i].success and results[i].trajectory is None
        assert "scheduler" in results[i].message


@pytest.mark.parametrize("client, error, words", [
    ("", InputError, "`client`"),
    ("inproc://x", InputError, "`client`"),
    ("  ", InputError, "`client`"),
    (3, InputTypeError, "`client`"),
])
def test_a_client_that_names_no_scheduler_is_refused_naming_client(client, error, words):
    with pytest.raises(error, match=words):
        batch.optimize_many([knife_edge_parking(5)], client=client, progress=False)


def test_a_closed_client_is_refused_naming_client():
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
                            dashboard_address=":0") as client:
        pass
    with pytest.raises(InputError, match="`client`.*closed"):
        batch.optimize_many([knife_edge_parking(5)], client=client, progress=False)
    with pytest.raises(InputError, match="`client`.*closed"):
        batch.simulate_many(dmoc.discretize(dmoc.systems.knife_edge(), 0.1),
                            [{"q0": [0, 0, 0], "v0": [1, 0, 0], "steps": 3}], client=client,
                            progress=False)
