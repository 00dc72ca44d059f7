"""Runs in lockstep (dmoc.simulation.lockstep) give what `simulate` gives for each run alone
(the oracle: the existing single-run path, called run by run), field by field and bit for
bit, with the same status, message and stats but the wall time: runs that the fast path
converges throughout, runs whose steps the line-search Newton redoes (a kick), runs that
fail (no real solution, or a NaN force), both variants, a rule with stages, jit True,
False and None, runs of other lengths and variants mixed in, blocks of every width."""

from dataclasses import fields

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc._util import compiled
from dmoc.errors import InputError
from dmoc.simulation import lockstep
from dmoc.simulation.lockstep import simulate_lockstep, simulate_runs
from dmoc.simulation.preparation import memory_needed, prepare, prepare_runs

FIELDS = ("t", "q", "p", "lam", "u", "mu", "s")
JITS = [False, None, pytest.param(True, marks=pytest.mark.skipif(
    compiled.compiler() is None, reason="no C compiler"))]


def _pendulum():
    """L = v^2/2 + cos q, f = v^2 + u: a kick u = 20 needs the line-search Newton, a kick
    u = 300 leaves the midpoint step without a real solution, sqrt(u) of u < 0 is NaN."""
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2 + ca.cos(q[0]), 1,
                                 force=lambda q, v, u: 0.4 * v[0] ** 2 + u[0] + ca.sqrt(u[1]),
                                 n_u=2)


def _pendulum_runs(steps, variant):
    """Runs of `steps` steps: quiet ones, kicked ones (redone steps), failing ones at
    several steps, a NaN force, one failing at its first step."""
    runs = []
    for i in range(37):
        controls = np.zeros((steps, 2))
        controls[:, 0] = 0.01 * i
        if i % 5 == 1:
            controls[(3 * i) % steps, 0] = 20.0              # robust redo, then on
        if i % 7 == 2:
            controls[(5 * i) % steps, 0] = 300.0             # Newton fails there
        if i == 11:
            controls[steps // 2, 1] = -1.0                   # NaN force
        if i == 13:
            controls[0, 0] = 300.0                           # fails at once
        runs.append({"q0": [0.1 * i], "v0": [1.0 - 0.02 * i], "steps": steps,
                     "controls": controls, "variant": variant})
    return runs


def _assert_same(got, want):
    """`got` equals `want` bit for bit in every field, status, message and stats but the
    wall time."""
    assert (got.success, got.status, got.message) == (want.success, want.status, want.message)
    assert {k: v for k, v in got.stats.items() if k != "wall_time"} == \
        {k: v for k, v in want.stats.items() if k != "wall_time"}
    for name in FIELDS:
        a, b = getattr(got.trajectory, name), getattr(want.trajectory, name)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name
        assert a.flags.c_contiguous and a.flags.writeable, name     # rows of copies of their own
    for name in ("h", "variant", "control_nodes", "stage_nodes"):
        assert getattr(got.trajectory, name) == getattr(want.trajectory, name), name


def _serial(disc, runs):
    return [dmoc.simulate(disc, **run, throw=False) for run in runs]


@pytest.mark.parametrize("jit", JITS)
@pytest.mark.parametrize("variant", ["+", "-"])
def test_kicked_and_failing_runs_in_lockstep_equal_the_runs_alone(jit, variant):
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = [dict(run, jit=jit) for run in _pendulum_runs(40, variant)]
    want = _serial(disc, runs)
    got = simulate_runs(disc, runs)
    for a, b in zip(got, want):
        _assert_same(a, b)
    statuses = [r.status for r in want]
    assert {"converged", "newton_failed", "non_finite"} <= set(statuses)
    assert any(r.success and r.stats["robust_steps"] for r in want)
    assert any(r.stats["completed_steps"] == 0 for r in want)


@pytest.mark.parametrize("jit", JITS)
@pytest.mark.parametrize("rule", ["midpoint", "lobatto3"])
def test_mixed_lengths_variants_and_tolerances_come_back_in_order(jit, rule):
    """Groups of several lengths, variants and tolerances (one of them failing every
    run), a rule with stages and its controls at the nodes, h shared by two
    discretizations of one stepper."""
    disc = dmoc.discretize(dmoc.systems.rolling_disk(), 0.05, rule=rule)
    runs = []
    for i in range(40):
        steps = (33, 1, 70)[i % 3]
        run = {"q0": [0.1 * i, 0, 0, 0], "v0": [1, 0, 1, 0.5 - 0.01 * i], "steps": steps,
               "variant": "+-"[i % 2], "jit": jit}
        if i % 4 == 0:
            run["controls"] = np.column_stack([np.sin(0.1 * np.arange(steps) + i),
                                               np.cos(0.2 * np.arange(steps))])
        if i % 9 == 0:
            run["tol"] = 1e-300
        runs.append(run)
    for a, b in zip(simulate_runs(disc, runs), _serial(disc, runs)):
        _assert_same(a, b)


def test_small_groups_and_every_block_width(monkeypatch):
    """Groups cut by the memory bound (here 3 runs) and by nothing (blocks of 16, 8, 4, 2,
    1 runs for 31) give the same results."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.01)
    runs = [{"q0": [0, 0, 0.01 * i], "v0": [np.cos(0.01 * i), np.sin(0.01 * i), 1.0],
             "steps": 300} for i in range(31)]
    want = _serial(disc, runs)
    for a, b in zip(simulate_runs(disc, runs), want):
        _assert_same(a, b)
    bytes_of_one = memory_needed(disc, 300)
    monkeypatch.setattr(lockstep, "GROUP_BYTES", 3 * bytes_of_one)
    assert [len(g) for g in lockstep.groups([prepare(disc, **run) for run in runs])] == [3] * 10 + [1]
    for a, b in zip(simulate_runs(disc, runs), want):
        _assert_same(a, b)


def test_with_throw_the_first_failed_run_raises_as_simulate_does():
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = _pendulum_runs(20, "+")[:4]
    prepared = [prepare(disc, **run) for run in runs]
    with pytest.raises(dmoc.SolverError) as info:
        simulate_lockstep(prepared)
    first = next(run for run in runs if not dmoc.simulate(disc, **run, throw=False).success)
    with pytest.raises(dmoc.SolverError) as alone:
        dmoc.simulate(disc, **first)
    assert str(info.value) == str(alone.value)


def test_bad_arguments_raise_as_simulate_does():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    with pytest.raises(InputError, match="`q0`"):
        simulate_runs(disc, [{"q0": [0, 0, 0], "v0": [1, 0, 1], "steps": 5},
                             {"q0": [0, 0], "v0": [1, 0, 1], "steps": 5}])


def test_an_interrupt_keeps_the_chunks_before(monkeypatch):
    """Ctrl-C during the second chunk: every run keeps the first chunk's steps, status
    "interrupted", as `simulate` keeps the chunks before an interrupt."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.01)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 96} for c in (0.5, 1.0, 2.0)]
    evaluate, calls = lockstep._evaluate, []

    def interrupted(*args):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return evaluate(*args)
    monkeypatch.setattr(lockstep, "_evaluate", interrupted)
    got = simulate_runs(disc, runs)
    whole = _serial(disc, runs)
    for a, b in zip(got, whole):
        assert a.status == "interrupted" and a.stats["completed_steps"] == 64
        assert np.array_equal(a.trajectory.q, b.trajectory.q[:65])
        assert [f.name for f in fields(a)] == [f.name for f in fields(b)]


@pytest.mark.parametrize("variant", ["+", "-"])
def test_final_assembles_the_last_knot_of_each_run_as_final_knot_cuts_it(variant):
    """``final=True``: each trajectory is the last knot of `simulate`'s, cut as the batch
    cuts a whole one (`final_knot`), every other field of the result unchanged; runs that
    fail (the knot they reached) included."""
    from dmoc.batch.tasks import final_knot
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = _pendulum_runs(40, variant)
    want = _serial(disc, runs)
    got = simulate_lockstep([prepare(disc, **run, throw=False) for run in runs], final=True)
    for a, b in zip(got, want):
        b.trajectory = final_knot(b.trajectory)
        _assert_same(a, b)
        assert a.trajectory.q.shape == (1, 1) and a.trajectory.u.shape == (0, 2)


def test_each_bad_run_gets_the_error_simulate_raises_for_it_alone():
    """`prepare_runs` keeps each run's own error, the first check it fails in
    `simulate`'s order (a v0 off the constraints before bad controls), type and
    message; the good runs among them are prepared as `prepare` prepares them."""
    disc = dmoc.discretize(dmoc.systems.rolling_disk(), 0.05)
    good = {"q0": [0, 0, 0, 0], "v0": [1, 0, 1, 0.5], "steps": 7}
    bad = [{"q0": [0, 0, 0], "v0": [1, 0, 1, 0.5]}, {"p0": [0, 0, 0, 0]},
           {"v0": [1, 1, 1, 0.5]}, {"v0": [1, 1, 1, 0.5], "controls": np.zeros((3, 2))},
           {"controls": np.zeros((3, 2))}, {"tol": -1.0}, {"jit": 1}, {"steps": 0},
           {"v0": None, "p0": [1, 2]}, {"v0": [1, 0, np.nan, 0]}, {"variant": "x"},
           {"steps": 10 ** 15}]
    runs = []
    for i, change in enumerate(bad):            # each bad run followed by a good one
        runs += [dict(good, **change), dict(good, q0=[0.1 * i, 0, 0, 0])]
    prepared = prepare_runs(disc, runs)
    for run, got in zip(runs, prepared):
        try:
            want = prepare(disc, **run)
        except Exception as err:            # noqa: BLE001 - the oracle's own error
            assert type(got) is type(err) and str(got) == str(err)
            with pytest.raises(type(err)) as alone:
                dmoc.simulate(disc, **run)
            assert str(alone.value) == str(err)
        else:
            assert np.array_equal(got.start, want.start) and got.stepper is want.stepper
            assert np.array_equal(got.controls, want.controls)
    assert sum(isinstance(r, Exception) for r in prepared) == len(bad)
    assert "violates the velocity constraints" in str(prepared[4])
    assert "violates the velocity constraints" in str(prepared[6])


def test_start_momenta_of_many_runs_have_the_bits_of_one_run_each():
    """More runs than one mapped call takes (blocks of 64, 32, 4): each start momentum
    and each result as `simulate` alone gives it."""
    disc = dmoc.discretize(dmoc.systems.rolling_disk(), 0.05)
    rng = np.random.default_rng(3)
    runs = []
    for i in range(100):
        q0, roll = rng.normal(size=4) * 3, rng.normal()      # x' = cos(phi) theta', ...
        runs.append({"q0": q0, "v0": [np.cos(q0[3]) * roll, np.sin(q0[3]) * roll, roll,
                                      rng.normal()], "steps": 4})
    for a, b in zip(simulate_runs(disc, runs), _serial(disc, runs)):
        _assert_same(a, b)


@pytest.mark.parametrize("variant", ["+", "-"])
def test_a_group_concludes_into_rows_of_its_own_copies(variant):
    """The runs of a group that complete every step get rows of one copy per field
    (`conclude_group`): each run's rows its own (no run's arrays overlap another's), and
    not the scratch memory of the lockstep, which the next group reuses (the first
    results stay those of `simulate` after a second call on other runs)."""
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = _pendulum_runs(40, variant)
    first = simulate_runs(disc, runs)
    simulate_runs(disc, [dict(run, q0=[1.0 - 0.1 * i]) for i, run in enumerate(runs)])
    for a, b in zip(first, _serial(disc, runs)):
        _assert_same(a, b)
    whole = [r.trajectory for r in first if r.success]
    assert len(whole) > 10 and not whole[0].q.flags.owndata
    for one, other in zip(whole, whole[1:]):
        for name in FIELDS:
            assert not np.shares_memory(getattr(one, name), getattr(other, name)), name


def test_runs_checked_together_get_what_each_alone_gets(monkeypatch):
    """`prepare_runs` checks the scalars of equal runs once and the q0 and v0 given as
    plain numbers as one array (`_plain_rows`): on runs of every kind of value (lists
    and tuples of floats, ints, huge ints, bools, numpy scalars, arrays of other dtypes
    and shapes, NaN and infinities, strings, scalars of other types), each run gets the
    error that `prepare` raises for it alone with every array checked by `checks.array`
    (the oracle: `_plain_rows` switched off), type and message, or the same start, bits
    and stepper."""
    from dmoc.simulation import preparation
    disc = dmoc.discretize(dmoc.systems.rolling_disk(), 0.05)
    good_v0 = [1.0, 0.0, 1.0, 0.5]
    q0s = [[0, 0, 0, 0], (0.1, 0.2, 0.3, 0.0), [1, 2.5, 3, np.float64(0.0)],
           np.array([3.0, 2, 1, 0]), (0.1, 0.2, 0.3, 0.4), np.arange(4.0),
           np.arange(4), np.arange(4, dtype=np.float32), [2 ** 60, 0, 0, 0], [2 ** 70, 0, 0, 0],
           [True, 0, 0, 0], [True, False, False, True], [0, 0, np.nan, 0], [0, np.inf, 0, 0],
           [0, 0, 0], np.zeros((1, 4)), ["0", 0, 0, 0], [np.int64(3), 0, 0, 0],
           [np.float32(0.1), 0, 0, 0], [[0], 0, 0, 0]]
    v0s = [good_v0, tuple(good_v0), np.array(good_v0), [1, 0, 1, 0], [1, 1, 1, 0.5],
           [np.nan, 0, 1, 0], [1, 0, 1], "v"]
    scalars = [{}, {"steps": 7}, {"steps": 7.0}, {"steps": True}, {"tol": 1e-10},
               {"tol": np.float64(1e-10)}, {"tol": 0}, {"max_iter": np.int64(5)},
               {"throw": 0}, {"throw": np.bool_(False)}, {"variant": "-"}, {"variant": "x"}]
    rng = np.random.default_rng(5)
    runs = []
    for k in range(300):
        bad = k % 2                         # every other run of good values only
        run = {"q0": q0s[rng.integers(len(q0s) if bad else 4)],
               "v0": v0s[rng.integers(len(v0s) if bad else 3)],
               "steps": 5, **scalars[rng.integers(len(scalars) if bad else 2)]}
        if k % 17 == 0:
            run = {"q0": run["q0"], "p0": run.pop("v0"), "steps": 5}
        runs.append(run)
    prepared = prepare_runs(disc, runs)
    monkeypatch.setattr(preparation, "_plain_rows", lambda n, runs: {})
    kinds = set()
    for run, got in zip(runs, prepared):
        try:
            want = prepare(disc, **run)
        except Exception as err:            # noqa: BLE001 - the oracle's own error
            assert type(got) is type(err) and str(got) == str(err), run
            kinds.add(type(err))
        else:
            assert not isinstance(got, Exception), (run, got)
            assert got.start.tobytes() == want.start.tobytes() and got.stepper is want.stepper
            assert (got.throw, got.tol, got.formulation) == (want.throw, want.tol, want.formulation)
            assert got.controls.shape == want.controls.shape
    assert sum(isinstance(r, Exception) for r in prepared) > 50
    assert sum(not isinstance(r, Exception) for r in prepared) > 100
    assert len(kinds) >= 2


@pytest.mark.parametrize("seed", [0, 1])
def test_random_groups_with_failing_runs_equal_the_runs_alone(seed):
    """Random runs of the pendulum (random lengths from a few, so that groups hold runs
    that complete every step, concluded together, next to runs that fail or are redone,
    concluded one by one; random variants, kicks and NaN forces): every result, with
    the whole trajectory or the last knot only, as `simulate` gives it alone."""
    rng = np.random.default_rng(seed)
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = []
    for _ in range(60):
        steps = int(rng.choice([1, 7, 30]))
        controls = np.zeros((steps, 2))
        controls[:, 0] = rng.normal(scale=0.1, size=steps)
        kick = rng.integers(steps)
        controls[kick, 0] += rng.choice([0.0, 0.0, 20.0, 300.0])
        controls[kick, 1] = -1.0 if rng.random() < 0.05 else 0.0
        runs.append({"q0": [rng.normal()], "v0": [rng.normal()], "steps": steps,
                     "controls": controls, "variant": str(rng.choice(["+", "-"]))})
    want = _serial(disc, runs)
    assert {"converged", "newton_failed"} <= {r.status for r in want}
    for a, b in zip(simulate_runs(disc, runs), want):
        _assert_same(a, b)
    from dmoc.batch.tasks import final_knot
    finals = simulate_lockstep([prepare(disc, **run, throw=False) for run in runs], final=True)
    for a, b in zip(finals, want):
        b.trajectory = final_knot(b.trajectory)
        _assert_same(a, b)


def test_each_run_of_a_group_times_its_wall_from_its_own_start():
    """``stats["wall_time"]`` of each run of a group that completes every step counts
    from that run's own `tic` (when its stepper was asked for), not another run's: runs
    given starts 10 s apart get wall times 10 s apart, each within the clock readings
    around the call (the oracle: the tics set here and `time.perf_counter`)."""
    import time
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    prepared = [prepare(disc, q0=[0, 0, 0], v0=[c, 0, 1], steps=5, throw=False)
                for c in (0.5, 1.0, 2.0, 3.0)]
    assert len(lockstep.groups(prepared)) == 1
    base = time.perf_counter()
    for i, run in enumerate(prepared):
        run.tic = base - 10.0 * (3 - i)
    before = time.perf_counter()
    results = simulate_lockstep(prepared)
    after = time.perf_counter()
    for run, result in zip(prepared, results):
        assert result.success
        assert before - run.tic <= result.stats["wall_time"] <= after - run.tic


def test_each_run_starts_from_its_own_q0_p0_and_h_v0():
    """`prepare_runs` of runs of one stepper (velocities and momenta given, mixed): each
    run's start state is its own q0, its p0 (dL/dv = v0 for L = |v|^2 / 2), h v0 as the
    first Newton increment (zeros without v0) and zeros elsewhere (the oracle: the state
    built by hand from the layout). The start guess only steers Newton, so the results
    alone do not show a wrong one."""
    disc = dmoc.discretize(dmoc.MechanicalSystem(
        lambda q, v: 0.5 * (v[0] ** 2 + v[1] ** 2), 2), 0.3)
    runs = [{"q0": [1.0 * i, -0.5 * i], "steps": 3,
             **({"v0": [0.7 + i, 2.0 - i]} if i % 2 else {"p0": [0.1 * i, 1.5]})}
            for i in range(6)]
    prepared = prepare_runs(disc, runs)
    assert len({id(run.stepper) for run in prepared}) == 1
    for given, run in zip(runs, prepared):
        state = run.stepper.state
        want = np.zeros(state.size)
        want[state.slice("q")] = given["q0"]
        want[state.slice("p")] = given.get("p0", given.get("v0"))
        want[state.slice("dq")] = 0.3 * np.array(given["v0"]) if "v0" in given else 0.0
        np.testing.assert_allclose(run.start, want, rtol=1e-15, atol=0)


@pytest.mark.parametrize("variant", ["+", "-"])
def test_final_keeps_the_last_knot_of_the_whole_trajectory_cut_by_hand(variant):
    """``final=True`` on a group of runs (a rule with stages): each trajectory is the
    whole one of `simulate` alone sliced by hand with numpy (t, q, p of the last knot;
    lam, u, s with no row, their widths kept; h, mu and the nodes unchanged), not through
    `Trajectory.assembled`'s own cut."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    runs = [{"q0": [0, 0, 0.1 * i], "v0": [np.cos(0.1 * i), np.sin(0.1 * i), 1.0],
             "steps": 6, "variant": variant} for i in range(4)]
    whole = _serial(disc, runs)
    got = simulate_lockstep([prepare(disc, **run, throw=False) for run in runs], final=True)
    for a, b in zip(got, whole):
        assert a.success and b.success
        want = b.trajectory
        assert want.s.shape[1] > 0
        for name in ("t", "q", "p"):
            np.testing.assert_array_equal(getattr(a.trajectory, name), getattr(want, name)[-1:])
        for name in ("lam", "u", "s"):
            assert getattr(a.trajectory, name).shape == (0,) + getattr(want, name).shape[1:], name
        np.testing.assert_array_equal(a.trajectory.mu, want.mu)
        assert a.trajectory.h == want.h and a.trajectory.stage_nodes == want.stage_nodes


def test_arrays_of_other_dtypes_are_checked_as_checks_array_checks_them(monkeypatch):
    """q0 and v0 given as numpy arrays of shape (n,) but not float64 (booleans, strings,
    objects, complex, ints, float32) among good runs: `prepare_runs` gives each run the
    error or start that `prepare` gives it alone with every array checked by
    `checks.array` (the oracle: `_plain_rows` switched off)."""
    from dmoc.simulation import preparation
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    arrays = [np.array([True, False, True]), np.array(["0", "1", "0"]),
              np.array([0.0, 1, 0], dtype=object), np.array([0, 1j, 0]),
              np.array([0, 2 ** 62, 1]), np.arange(3, dtype=np.float32),
              np.arange(3, dtype=np.uint8)]
    runs = []
    for a in arrays:
        runs += [{"q0": a, "v0": [1.0, 0.0, 1.0], "steps": 3},
                 {"q0": [0.0, 0.0, 0.0], "v0": a, "steps": 3},
                 {"q0": [0.5, 0.0, 0.0], "v0": [1.0, 0.0, 1.0], "steps": 3}]
    prepared = prepare_runs(disc, runs)
    monkeypatch.setattr(preparation, "_plain_rows", lambda n, runs: {})
    errors = 0
    for run, got in zip(runs, prepared):
        try:
            want = prepare(disc, **run)
        except Exception as err:            # noqa: BLE001 - the oracle's own error
            assert type(got) is type(err) and str(got) == str(err), run
            errors += 1
        else:
            assert not isinstance(got, Exception), (run, got)
            assert got.start.tobytes() == want.start.tobytes()
    assert errors >= 6


def test_a_group_concludes_into_the_memory_it_is_given():
    """With `memory`, each group's trajectories are copied straight into the one float
    array ``memory(size)`` gives for it (as a batch writes them into the client's shared
    memory): every field of every run that completed is a view of one of those arrays,
    the runs' arrays do not overlap, the results are those of `simulate`, and the group
    asked for exactly what its runs' fields hold."""
    disc = dmoc.discretize(_pendulum(), 0.1)
    runs = _pendulum_runs(12, "+")
    given = []

    def memory(size):
        given.append(np.full(size, np.nan))
        return given[-1]

    results = simulate_lockstep(prepare_runs(disc, [dict(run, throw=False) for run in runs]),
                                memory=memory)
    for got, want in zip(results, _serial(disc, runs)):
        _assert_same(got, want)
    whole = [r.trajectory for r in results if r.success]
    assert len(given) == 1 and len(whole) > 10
    spans = []                                          # bytes of `given[0]` each field covers
    for traj in whole:
        for name in FIELDS:
            a = getattr(traj, name)
            start = a.ctypes.data - given[0].ctypes.data
            assert a.flags.c_contiguous and 0 <= start <= given[0].nbytes - a.nbytes, name
            if a.size:
                spans.append((start, start + a.nbytes))
    spans.sort()
    assert all(end <= start for (_, end), (start, _) in zip(spans, spans[1:]))   # no overlap
    assert sum(end - start for start, end in spans) == given[0].nbytes           # no more asked
    assert not np.isnan(given[0]).any()                 # every float handed out is a field's
