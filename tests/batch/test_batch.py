"""dmoc.batch: many solves on a 2-worker LocalCluster give exactly the serial results, in
input order; a failing solve, an exception in a task and a killed worker stay confined to
their own result. The oracle is the serial in-process `dmoc.optimize` / `dmoc.simulate`."""

import importlib.util
import os
import pathlib
import re
import signal
import subprocess
import sys

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.problems import knife_edge_parking, parking_goals  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402
from tests._helpers import same  # noqa: E402

GOALS = parking_goals()


def _cluster(**scheduler_kwargs):
    return distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                    dashboard_address=":0", scheduler_kwargs=scheduler_kwargs)


@pytest.fixture(scope="module")
def client():
    with _cluster() as cluster, distributed.Client(cluster) as client:
        yield client


def _assert_same_as_serial(problems, results, serial=None):
    serial = serial or [dmoc.optimize(p, throw=False) for p in problems]
    assert len(results) == len(problems)
    for problem, got, want in zip(problems, results, serial):
        assert got.success and want.success
        assert abs(got.cost - want.cost) <= 1e-10
        assert np.abs(got.trajectory.q - want.trajectory.q).max() <= 1e-10
        assert np.array_equal(got.trajectory.q[-1], problem.q_goal)   # order preserved


def _kill_once(flag):
    """A guess that SIGKILLs the first worker process unpickling it (creating `flag`), and
    is None on the workers after: it kills one worker mid-batch, deterministically. It stays
    armed in this process, where the scheduler of a LocalCluster unpickles and re-pickles
    task arguments."""
    here = os.getpid()

    def arm_or_fire():
        if os.getpid() == here:
            return Killer()
        if not flag.exists():
            flag.touch()
            os.kill(os.getpid(), signal.SIGKILL)
        return None

    class Killer(dmoc.Trajectory):
        def __init__(self):
            pass

        def __reduce__(self):
            return arm_or_fire, ()

    return Killer()


def _fail_once_outside_the_solve(flag):
    """Run on a worker: its dmoc.batch item guards see a `distributed` whose get_worker()
    raises the first time any worker calls it (creating `flag`), so exactly one task errs
    once after dmoc's own call returned (an error of the worker, not of the solve)."""
    from dmoc.batch import item_guard

    real = item_guard.distributed

    class FailsOnce:
        def __getattr__(self, name):
            return getattr(real, name)

        def get_worker(self):
            try:
                flag.touch(exist_ok=False)
            except FileExistsError:
                return real.get_worker()
            raise RuntimeError("the worker failed outside dmoc's call")

    item_guard.distributed = FailsOnce()


def test_import_dmoc_does_not_import_dask():
    code = ("import sys, dmoc; assert 'distributed' not in sys.modules and 'dask' not in "
            "sys.modules; dmoc.batch.optimize_many; assert 'distributed' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True,
                   cwd=os.path.dirname(os.path.dirname(dmoc.__file__)))


def test_64_parking_problems_match_serial_solves(client, capsys):
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS]
    results = batch.optimize_many(problems, client=client)
    _assert_same_as_serial(problems, results)
    assert {r.stats["worker"] for r in results} == set(client.scheduler_info()["workers"])
    err = capsys.readouterr().err             # captured, not a terminal: plain lines
    bar = [line for line in err.splitlines() if line.startswith("optimize [")]
    assert "\r" not in err and 2 <= len(bar) <= 11
    last = bar[-1]
    assert re.fullmatch(r"optimize \[#{30}\] 64/64 elapsed \d+:\d\d eta 0:00", last), last


def test_default_cluster_and_scheduler_address(client, capsys):
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:3]]
    serial = [dmoc.optimize(p) for p in problems]
    _assert_same_as_serial(problems, batch.optimize_many(problems, progress=False), serial)
    by_address = batch.optimize_many(problems, client=client.scheduler_info()["address"], progress=False)
    _assert_same_as_serial(problems, by_address, serial)
    assert capsys.readouterr().err == ""
    assert client.status == "running"                 # a given Client is left open


def test_warm_start_from_guesses(client):
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:4]]
    seeds = batch.optimize_many(problems, client=client, progress=False)
    guesses = [seeds[0].trajectory, None, seeds[0].trajectory, seeds[3].trajectory]
    results = batch.optimize_many(problems, guesses=guesses, client=client, progress=False)
    serial = [dmoc.optimize(p, guess=g) for p, g in zip(problems, guesses)]
    _assert_same_as_serial(problems, results, serial)
    assert results[3].stats["iterations"] <= 1
    moved = [p.with_boundary(q_goal=p.q_goal + [0.0, 0.05, 0.0]) for p in problems]
    warm = batch.optimize_many(moved, guesses=seeds, client=client, progress=False)
    _assert_same_as_serial(moved, warm, [dmoc.optimize(p, guess=g) for p, g in zip(moved, seeds)])
    assert all(r.stats["warm_start"] for r in warm)


def test_failures_stay_in_their_own_result(client):
    good = knife_edge_parking(20)
    infeasible = dmoc.OptimalControlProblem(good.disc, 20, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                            control_bounds=([0, 0], [0, 0]))
    short = dmoc.optimize(knife_edge_parking(10), check=False).trajectory
    wrong = dmoc.Trajectory(short.t, short.q[:, :2], short.p[:, :2], short.lam, short.u,
                            short.h, "+")
    results = batch.optimize_many([good, infeasible, good, good], guesses=[None, None, wrong, None],
                                  client=client, progress=False)
    assert [r.success for r in results] == [True, False, False, True]
    assert results[1].status == "Infeasible_Problem_Detected"
    assert results[1].trajectory is not None
    assert results[2].status == "exception" and results[2].trajectory is None
    assert "`guess`" in results[2].message and "InputError" in results[2].stats["traceback"]
    assert np.isnan(results[2].cost)
    _assert_same_as_serial([good, good], [results[0], results[3]])


def test_killed_worker_loses_no_result(tmp_path):
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:12]]
    guesses = [None] * len(problems)
    guesses[5] = _kill_once(tmp_path / "killed")
    with _cluster() as cluster, distributed.Client(cluster) as client:
        results = batch.optimize_many(problems, guesses=guesses, client=client, progress=False)
        removed = client.run_on_scheduler(lambda dask_scheduler: dask_scheduler._workers_removed_total)
    assert (tmp_path / "killed").exists() and removed >= 1
    _assert_same_as_serial(problems, results)


def test_task_that_errs_once_outside_the_solve_is_run_again(tmp_path):
    """A task that raises outside dmoc's own call (which reports its errors as results) is
    run again by dask (`retries`): every result is the serial one."""
    problems = [knife_edge_parking(20, goal=goal) for goal in GOALS[:3]]
    with _cluster() as cluster, distributed.Client(cluster) as client:
        client.run(_fail_once_outside_the_solve, tmp_path / "failed")
        results = batch.optimize_many(problems, client=client, progress=False)
    assert (tmp_path / "failed").exists()
    _assert_same_as_serial(problems, results)


def test_task_whose_workers_keep_dying_is_reported_lost(tmp_path):
    problems = [knife_edge_parking(20)]
    with _cluster(allowed_failures=0) as cluster, distributed.Client(cluster) as client:
        results = batch.optimize_many(problems, guesses=[_kill_once(tmp_path / "killed")],
                                      client=client, progress=False)
    assert results[0].status == "worker_lost" and not results[0].success
    assert "KilledWorker" in results[0].message and results[0].trajectory is None


def test_simulate_many_matches_serial_runs(client):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    fine = dmoc.discretize(dmoc.systems.knife_edge(), 0.01)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 40, "variant": v}
            for c in (0.5, 1.0, 2.0) for v in ("+", "-")]
    runs += [{"q0": [0, 0], "v0": [1, 0, 1], "steps": 40},
             {"q0": [0, 0, 0], "v0": [1, 0, 1], "steps": 40, "tol": 1e-300}]
    discs = [disc] * 6 + [fine, fine]
    results = batch.simulate_many(discs, runs, client=client, progress=False)
    for got, d, run in zip(results[:6], discs, runs):
        want = dmoc.simulate(d, **run)
        assert got.success and np.array_equal(got.trajectory.q, want.trajectory.q)
        assert np.array_equal(got.trajectory.p, want.trajectory.p)
    assert results[6].status == "exception" and "`q0`" in results[6].message
    failed = dmoc.simulate(fine, **runs[7], throw=False)
    assert results[7].status == failed.status == "newton_failed"
    assert np.array_equal(results[7].trajectory.q, failed.trajectory.q)
    assert results[7].trajectory.steps < 40
    one_disc = batch.simulate_many(disc, runs[:2], client=client, progress=False)
    assert [np.array_equal(a.trajectory.q, b.trajectory.q) for a, b in zip(one_disc, results)] == [True, True]


def test_simulate_many_keeps_only_the_final_knot_on_request(client):
    """keep="final": each result holds the last knot of the serial run (the oracle), a
    Newton failure's too, with the whole run's stats."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 40, "variant": v}
            for c in (0.5, 2.0) for v in ("+", "-")]
    runs.append({"q0": [0, 0, 0], "v0": [1, 0, 1], "steps": 40, "tol": 1e-300})
    results = batch.simulate_many(disc, runs, keep="final", client=client, progress=False)
    for got, run in zip(results, runs):
        want = dmoc.simulate(disc, **run, throw=False)
        assert got.status == want.status and got.stats["completed_steps"] == want.stats["completed_steps"]
        assert got.trajectory.steps == 0 and got.trajectory.t.tolist() == want.trajectory.t[-1:].tolist()
        assert np.array_equal(got.trajectory.q, want.trajectory.q[-1:])
        assert np.array_equal(got.trajectory.p, want.trajectory.p[-1:])
        assert np.array_equal(got.trajectory.mu, want.trajectory.mu)
    assert results[-1].status == "newton_failed" and results[-1].stats["completed_steps"] < 40


def test_simulate_many_on_the_rotation_group_matches_serial_runs(client):
    """Rigid bodies on SO(3) (GroupDiscretization): each result is the serial `simulate`'s
    (the oracle) bit for bit, every field of its RotationTrajectory; a run the simulator
    refuses is its own "exception"; keep="final" holds the serial run's last knot."""
    r, J = 0.7, (1.0, 1.5, 2.5)
    ball = dmoc.discretize(dmoc.systems.chaplygin_sphere(J, 1.3, r, torques=True), 0.1)
    top = dmoc.discretize(dmoc.systems.heavy_top(J, 1.0, (0.05, 0.0, 0.5), 9.81), 0.05)
    R0 = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    rolls = [{"q0": (R0, [0.2, -0.1]), "v0": np.concatenate([w, r * np.cross(R0 @ w, [0, 0, 1])[:2]]),
              "steps": 20, "controls": np.full((20, 3), c)}
             for w, c in ((np.array([1.0, -0.5, 2.0]), 0.0), (np.array([0.2, 0.4, -1.0]), 0.3))]
    runs = rolls + [{"q0": R0, "v0": [0.5, -0.3, 8.0], "steps": 20}, {"q0": R0, "v0": [1, 0, 0], "steps": 20}]
    discs = [ball, ball, top, ball]
    results = batch.simulate_many(discs, runs, client=client, progress=False)
    for got, d, run in zip(results[:3], discs, runs):
        want = dmoc.simulate(d, **run)
        assert got.success and isinstance(got.trajectory, dmoc.RotationTrajectory)
        assert same(got.trajectory, want.trajectory)
    assert results[3].status == "exception" and "`q0` must be the pair (R_0, x_0)" in results[3].message
    finals = batch.simulate_many(ball, rolls, keep="final", client=client, progress=False)
    for got, run in zip(finals, rolls):
        want = dmoc.simulate(ball, **run).trajectory
        assert got.trajectory.steps == 0 and np.array_equal(got.trajectory.R, want.R[-1:])
        assert np.array_equal(got.trajectory.p, want.p[-1:]) and np.array_equal(got.trajectory.x, want.x[-1:])


def test_problem_round_trips_through_bytes():
    problem = dmoc.problems.rolling_disk_steering(20, variant="-")
    copy = batch.unpack_problem(batch.pack_problem(problem))
    assert copy.nlp["x"].shape == problem.nlp["x"].shape
    assert dmoc.optimize(copy).cost == dmoc.optimize(problem).cost


@pytest.mark.parametrize("kwargs, error, match", [
    ({"problems": knife_edge_parking(20)}, TypeError, "`problems` must be a sequence"),
    ({"problems": [knife_edge_parking(20), "x"]}, TypeError, "item 1 is a str"),
    ({"problems": [knife_edge_parking(20)], "guesses": []}, ValueError, "`guesses` must have one"),
    ({"problems": [knife_edge_parking(20)], "guesses": [1]}, TypeError, "`guesses`"),
    ({"problems": [knife_edge_parking(20)], "options": 3}, TypeError, "`options`"),
    ({"problems": [knife_edge_parking(20)], "client": 3}, TypeError, "`client` must be None"),
    ({"problems": [knife_edge_parking(20)], "progress": "yes"}, TypeError, "`progress`"),
])
def test_optimize_many_rejects_bad_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        batch.optimize_many(**kwargs)


def test_simulate_many_rejects_bad_arguments():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    run = {"q0": [0, 0, 0], "v0": [1, 0, 1], "steps": 4}
    with pytest.raises(ValueError, match="runs\\[0\\]"):
        batch.simulate_many(disc, [{**run, "throw": True}])
    with pytest.raises(ValueError, match="`disc` must be one Discretization"):
        batch.simulate_many([disc, disc], [run])
    with pytest.raises(TypeError, match="`runs` must be a sequence of dict"):
        batch.simulate_many(disc, [run, 3])
    with pytest.raises(ValueError, match="`keep` must be one of 'trajectory', 'final'; got 'last'"):
        batch.simulate_many(disc, [run], keep="last")
    for given, lacks in (({}, "`q0` and `steps`"), ({"q0": [0, 0, 0]}, "`steps`")):
        with pytest.raises(ValueError, match=f"`runs\\[1\\]` must give `q0` and `steps` of "
                                             f"`simulate`; it lacks {lacks}") as raised:
            batch.simulate_many(disc, [run, given])
        assert "_given" not in str(raised.value)


def test_motion_primitives_example(client, tmp_path, capsys):
    spec = importlib.util.spec_from_file_location(
        "motion_primitives", pathlib.Path(__file__).parents[2] / "examples" / "motion_primitives.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    waves = example.waves()
    assert [len(w) for w in waves] == [1, 8, 16]
    for d, wave in enumerate(waves[1:], start=1):       # each warm start was solved before
        assert all(near in {c for c, _ in waves[d - 1]} for _, near in wave)
    solved = example.main(steps=20, out=tmp_path, client=client)
    assert len(solved) == 25 and all(r.success for r in solved.values())
    for (i, j), result in solved.items():               # mirror symmetry (y, theta) -> (-y, -theta)
        assert abs(result.cost - solved[4 - i, 4 - j].cost) <= 1e-8 * result.cost
        saved = dmoc.Trajectory.load(tmp_path / "motion_primitives" / f"y{i}_theta{j}.npz")
        assert np.array_equal(saved.q, result.trajectory.q)
    assert len((tmp_path / "motion_primitives.csv").read_text().splitlines()) == 26
    assert (tmp_path / "motion_primitives.png").stat().st_size > 1000
    assert "25/25 primitives solved" in capsys.readouterr().out


def test_packed_problem_leaves_its_assembled_derivatives_behind():
    """A solved problem packs to the same size as a fresh one (the worker rebuilds the
    derivatives), and the unpacked problem solves to the same cost."""
    problem = dmoc.problems.knife_edge_parking(20)
    fresh = len(dmoc.batch.pack_problem(problem))
    result = dmoc.optimize(problem)
    packed = dmoc.batch.pack_problem(problem)
    assert len(packed) <= fresh + 1000
    again = dmoc.optimize(dmoc.batch.unpack_problem(packed), reuse_solver=False)
    assert abs(again.cost - result.cost) <= 1e-12 * result.cost
