"""dmoc.batch never hangs and keeps items apart: an argument the workers cannot unpickle, a
SystemExit inside an item, an item that runs too long, a batch past its deadline, an
unreachable scheduler, a script without its main guard and Ctrl-C in the client each end
in bounded time, with every other result equal to the serial in-process solve (the
oracle). Each test runs under a wall-clock guard (`_within`, subprocess ``timeout=``), so
that a regression fails instead of hanging the suite."""

import json
import os
import pathlib
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.errors import DmocError  # noqa: E402
from dmoc.problems import knife_edge_parking, parking_goals  # noqa: E402

GOALS = parking_goals()
ROOT = pathlib.Path(__file__).parents[2]
GUARD = 120      # seconds after which a test that has not returned fails as a hang


def _within(seconds, call, *args, **kwargs):
    """call(*args, **kwargs) in a daemon thread; its value, its exception, or a test
    failure when it has not returned after `seconds`."""
    box = {}

    def target():
        try:
            box["value"] = call(*args, **kwargs)
        except BaseException as err:  # re-raised in the test's thread
            box["error"] = err

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        pytest.fail(f"the batch did not return within {seconds} s")
    if "error" in box:
        raise box["error"]
    return box["value"]


def _on_workers(action):
    """An object whose unpickling in any process but this one calls `action()` and
    yields None (in this process it stays itself): it runs `action` inside a worker's
    task, while the client and a LocalCluster's in-process scheduler can handle it."""
    here = os.getpid()

    def rebuild():
        if os.getpid() == here:
            return Armed()
        action()
        return None

    class Armed(dmoc.Trajectory):
        def __init__(self):
            pass

        def __reduce__(self):
            return rebuild, ()

    return Armed()


def _exit_on_workers():
    raise SystemExit(3)


def _sleep_on_workers():
    time.sleep(600)


def _exits_when_read(seed):
    """A copy of the Trajectory `seed` whose ``q`` raises SystemExit when read on a
    worker: the exit happens inside `optimize`, after the arguments are unpickled."""
    here = os.getpid()

    class Exiting(dmoc.Trajectory):
        def __getattribute__(self, name):
            if name == "q" and os.getpid() != here:
                raise SystemExit(4)
            return super().__getattribute__(name)

    return Exiting(seed.t, seed.q, seed.p, seed.lam, seed.u, seed.h, seed.variant)


def _assert_equal_to_serial(problems, results, indices):
    for i in indices:
        want = dmoc.optimize(problems[i])
        assert results[i].success and want.success
        assert abs(results[i].cost - want.cost) <= 1e-9
        assert np.array_equal(results[i].trajectory.q[-1], problems[i].q_goal)


def _workers_removed(client):
    return client.run_on_scheduler(lambda dask_scheduler: dask_scheduler._workers_removed_total)


def test_undeserializable_guess_is_its_own_result(client, tmp_path, monkeypatch):
    """The workers started before the module exists on the client's path, so they cannot
    import the guess's class."""
    (tmp_path / "client_only_guess.py").write_text(
        "import dmoc\n\n\nclass ClientOnlyGuess(dmoc.Trajectory):\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    from client_only_guess import ClientOnlyGuess
    seed = dmoc.optimize(knife_edge_parking(20)).trajectory
    guess = ClientOnlyGuess(seed.t, seed.q, seed.p, seed.lam, seed.u, seed.h, seed.variant)
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:4]]
    removed = _workers_removed(client)
    results = _within(GUARD, batch.optimize_many, problems, guesses=[None, guess, None, None],
                      client=client, progress=False)
    assert results[1].status == "undeserializable" and not results[1].success
    assert "ModuleNotFoundError" in results[1].message and "client_only_guess" in results[1].message
    assert results[1].trajectory is None and np.isnan(results[1].cost)
    _assert_equal_to_serial(problems, results, [0, 2, 3])
    assert _workers_removed(client) == removed                  # no worker died


def test_system_exit_in_an_item_does_not_touch_its_neighbours(client):
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:6]]
    seed = dmoc.optimize(problems[2]).trajectory
    guesses = [None, _on_workers(_exit_on_workers), _exits_when_read(seed), None, None, None]
    removed = _workers_removed(client)
    results = _within(GUARD, batch.optimize_many, problems, guesses=guesses, client=client,
                      progress=False)
    assert [r.success for r in results] == [True, False, False, True, True, True]
    assert results[1].status == "undeserializable" and "SystemExit: 3" in results[1].message
    assert results[2].status == "exception" and results[2].message == "SystemExit: 4"
    assert "SystemExit" in results[2].stats["traceback"]
    _assert_equal_to_serial(problems, results, [0, 3, 4, 5])
    assert _workers_removed(client) == removed


def test_item_past_its_timeout_is_its_own_result(client):
    """The sleeping item is abandoned after `timeout`; its worker is restarted, and the
    item queued behind it on that worker is solved elsewhere."""
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:4]]
    guesses = [None, _on_workers(_sleep_on_workers), None, None]
    results = _within(GUARD, batch.optimize_many, problems, guesses=guesses, client=client,
                      progress=False, timeout=4)
    assert results[1].status == "timeout" and not results[1].success
    assert "`timeout`=4 s" in results[1].message and results[1].trajectory is None
    _assert_equal_to_serial(problems, results, [0, 2, 3])
    client.wait_for_workers(2, timeout=60)
    after = batch.optimize_many(problems[:2], client=client, progress=False)
    _assert_equal_to_serial(problems, after, [0, 1])


def test_batch_past_its_deadline_returns_what_finished():
    """One worker runs the two simulations, then the sleeping run, which the deadline
    abandons (its own cluster: the worker stays busy with it until the cluster closes)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 40} for c in (0.5, 1.0)]
    runs.append({**runs[0], "controls": _on_workers(_sleep_on_workers)})
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        results = _within(GUARD, batch.simulate_many, disc, runs, client=client,
                          progress=False, batch_timeout=5)
    assert results[2].status == "timeout" and "`batch_timeout`=5 s" in results[2].message
    assert not results[2].success and results[2].trajectory is None
    for got, run in zip(results[:2], runs):
        assert got.success
        assert np.array_equal(got.trajectory.q, dmoc.simulate(disc, **run).trajectory.q)


def test_unreachable_scheduler_raises_within_the_connect_timeout():
    with socket.socket() as free:
        free.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{free.getsockname()[1]}"
    with pytest.raises(batch.SchedulerUnreachable, match=address) as caught:
        _within(GUARD, batch.optimize_many, [knife_edge_parking(20)], client=address,
                connect_timeout=1, progress=False)
    assert isinstance(caught.value, DmocError) and isinstance(caught.value, OSError)
    assert "`connect_timeout`=1 s" in str(caught.value)


def _script(tmp_path, body):
    path = tmp_path / "script.py"
    path.write_text(body)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return path, env


def test_script_without_main_guard_gets_the_dmoc_error(tmp_path):
    path, env = _script(tmp_path, "from dmoc.batch import optimize_many\n"
                                  "optimize_many([], progress=False)\n"
                                  "print('solved')\n")
    done = subprocess.run([sys.executable, str(path)], env=env, capture_output=True, text=True,
                          timeout=GUARD, check=False)
    assert done.returncode != 0 and "solved" not in done.stdout
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("dmoc.batch.failures.WorkersFailedToStart")
    assert 'if __name__ == "__main__":' in last and str(path) in last
    assert "while a worker process re-imported the script" in done.stderr   # the workers' own


CTRL_C = """
import json, os, time
import dmoc
from dmoc.batch import BatchInterrupted, optimize_many
from dmoc.problems import knife_edge_parking, parking_goals

here = os.getpid()


def rebuild():
    if os.getpid() != here:
        time.sleep(600)


class Sleeper(dmoc.Trajectory):
    def __init__(self):
        pass

    def __reduce__(self):
        return rebuild, ()


if __name__ == "__main__":
    problems = [knife_edge_parking(20, goal=g) for g in parking_goals()[:3]]
    try:
        optimize_many(problems, guesses=[None] * 2 + [Sleeper()])
    except BatchInterrupted as interrupt:
        assert isinstance(interrupt, KeyboardInterrupt)
        print(json.dumps([[r.status, r.cost, r.message] for r in interrupt.results]))
"""


def test_ctrl_c_returns_the_finished_results(tmp_path):
    """SIGINT once two of three items are done (the progress bar reads 2/3): the script's
    BatchInterrupted carries them, and the third is "interrupted"."""
    path, env = _script(tmp_path, CTRL_C)
    process = subprocess.Popen([sys.executable, str(path)], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE)
    try:
        seen = _within(GUARD, _read_until, process.stderr, b"] 2/3")
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=GUARD)
    finally:
        process.kill()
    assert seen.endswith(b"] 2/3") and process.returncode == 0, err.decode()[-2000:]
    results = json.loads(out)
    assert [status for status, _, _ in results[2:]] == ["interrupted"]
    assert "Ctrl-C" in results[2][2]
    for (status, cost, _), goal in zip(results[:2], GOALS):
        assert status == "Solve_Succeeded"
        assert abs(cost - dmoc.optimize(knife_edge_parking(20, goal=goal)).cost) <= 1e-9


def _read_until(stream, marker):
    seen = b""
    while not seen.endswith(marker):
        byte = stream.read(1)
        if not byte:
            raise EOFError(seen.decode()[-2000:])
        seen += byte
    return seen


def test_scheduler_without_workers_gives_worker_lost_results():
    """A scheduler that never gets a worker: the items fail after `connect_timeout`."""
    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        results = _within(GUARD, batch.optimize_many, [knife_edge_parking(20)] * 2,
                          client=client, progress=False, connect_timeout=1)
    assert [r.status for r in results] == ["worker_lost", "worker_lost"]
    assert "no worker for 1 s" in results[0].message and not results[0].success


CTRL_C_AT_START = """
import json, sys
import dmoc
from dmoc.batch import BatchInterrupted, cluster, optimize_many
from dmoc.problems import knife_edge_parking

checked = cluster.refuse_spawn_reimport


def starting():
    checked()
    print("starting", file=sys.stderr, flush=True)


if __name__ == "__main__":
    cluster.refuse_spawn_reimport = starting
    try:
        optimize_many([knife_edge_parking(5)] * 2, progress=False)
    except BatchInterrupted as interrupt:
        print(json.dumps([[r.status, r.message] for r in interrupt.results]))
"""


def test_ctrl_c_while_the_default_cluster_starts_is_a_batch_interrupted(tmp_path):
    """SIGINT while the LocalCluster of `client=None` starts: BatchInterrupted naming
    `client`, every item "interrupted", and no error of Dask's exit hook (its
    AssertionError on the half-started cluster)."""
    path, env = _script(tmp_path, CTRL_C_AT_START)
    process = subprocess.Popen([sys.executable, str(path)], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE)
    try:
        _within(GUARD, _read_until, process.stderr, b"starting")
        time.sleep(0.2)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=GUARD)
    finally:
        process.kill()
    assert process.returncode == 0, err.decode()[-2000:]
    assert json.loads(out) == [["interrupted", "Ctrl-C while the cluster (`client`) was starting"]] * 2
    # the half-started cluster is closed and forgotten: Dask's exit hook has nothing to fail on
    assert b"AssertionError" not in err and b"atexit" not in err, err.decode()[-2000:]
