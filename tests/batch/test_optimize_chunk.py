"""A worker's optimize chunk in this process (`dmoc.batch.tasks.optimize_chunk`): its optima
judged together without a timeout, each alone with one, and every item's result that of
``dmoc.optimize(..., throw=False)`` of its problem alone, bit for bit, whatever its
neighbours do (converge, fail IPOPT, fail the verdict, raise, fail to unpickle).

Oracle: the serial ``dmoc.optimize`` of each problem (its solve judged alone), and the
statuses of docs/batch.md ("Failure semantics") for the items that produce no solve.
"""

import numpy as np
import pytest

import dmoc
from dmoc.batch import item_guard, pack_problem, shipping, tasks
from dmoc.problems import knife_edge_parking

OPTIONS = {"max_iter": 12}          # the goal y = 5 needs 16 iterations: IPOPT fails it
GOALS = (0.2, 1.0, 2.0, -3.0, 5.0, 0.7)       # 2.0 and 5.0 under-resolved on 10 steps


@pytest.fixture(scope="module")
def shipped():
    """(digest, base problem) of knife-edge parking on 10 steps, shipped to this process as
    a `Shipment` sets it up on a worker."""
    base = knife_edge_parking(10)
    data = pack_problem(base)
    digest = shipping.digest(data)
    tasks.Shipment(digest, data).setup(None)
    yield digest, base
    tasks.Shipment(digest, data).teardown(None)


@pytest.fixture(autouse=True)
def no_worker(monkeypatch):
    for module in (tasks, item_guard):
        monkeypatch.setattr(module, "stamp", lambda results: None)     # no worker here


def items_and_oracles(base):
    """The items of a chunk and what ``dmoc.optimize`` gives each alone (None where the
    item produces no solve): goals that pass, fail the verdict and fail IPOPT, a guess of
    the wrong size (an InputError in the solve), bytes that do not unpickle."""
    problems = [base.with_boundary(q_goal=[0.0, y, 0.1]) for y in GOALS]
    short = dmoc.optimize(knife_edge_parking(10), check=False).trajectory
    wrong = dmoc.Trajectory(short.t, short.q[:, :2], short.p[:, :2], short.lam, short.u,
                            short.h, "+")
    guesses = [None] * len(problems)
    guesses[3] = wrong
    items = [bytes(shipping.item("guess", (shipping.boundary(p), p.parameter_values, g)))
             for p, g in zip(problems, guesses)]
    oracles = [dmoc.optimize(p, guess=g, options=OPTIONS, throw=False) if g is None else None
               for p, g in zip(problems, guesses)]
    items.insert(2, b"not a pickle")
    oracles.insert(2, None)
    return items, oracles


def assert_same(got, expected):
    assert got.x.tobytes() == expected.x.tobytes()
    assert np.float64(got.cost).tobytes() == np.float64(expected.cost).tobytes()
    assert (got.success, got.status, got.message) == (expected.success, expected.status,
                                                      expected.message)
    assert repr(got.verdict) == repr(expected.verdict)


def assert_chunk(results, oracles):
    assert len(results) == len(oracles)
    for got, expected in zip(results, oracles):
        if expected is not None:
            assert_same(got, expected)
    statuses = [r.status for r in results]
    assert statuses == ["Solve_Succeeded", "Solve_Succeeded", "undeserializable",
                        "under_resolved", "exception", "Maximum_Iterations_Exceeded",
                        "Solve_Succeeded"]
    assert "`guess`" in results[4].message and results[4].trajectory is None
    assert results[3].verdict.status == "under_resolved" and results[5].verdict is None


@pytest.mark.parametrize("timeout", [None, 60])
def test_a_chunk_gives_each_item_its_serial_result(shipped, timeout):
    digest, base = shipped
    items, oracles = items_and_oracles(base)
    results, seconds = tasks.optimize_chunk(digest, items, OPTIONS, {}, timeout)
    assert len(seconds) == len(items) and min(seconds) > 0
    assert_chunk(results, oracles)


@pytest.mark.parametrize("how", ["the group raises", "one verdict raises"])
def test_an_error_of_the_verdicts_stays_its_items(shipped, how, monkeypatch):
    """Should the verdicts of the group raise, each optimum is judged alone: the same
    results; an optimum whose verdict raises alone is that item's "exception"."""
    digest, base = shipped
    items, oracles = items_and_oracles(base)
    real_judge = tasks.judge

    def judge(problem, result):
        if how == "one verdict raises" and problem.q_goal[1] == GOALS[1]:
            raise RuntimeError("this optimum's verdict failed")
        return real_judge(problem, result)

    def verdicts(pairs):
        raise RuntimeError("the group failed")
    monkeypatch.setattr(tasks, "verdicts", verdicts)
    monkeypatch.setattr(tasks, "judge", judge)
    results, _ = tasks.optimize_chunk(digest, items, OPTIONS, {}, None)
    if how == "the group raises":
        assert_chunk(results, oracles)
        return
    failed = results[1]
    assert failed.status == "exception" and not failed.success and failed.trajectory is None
    assert "RuntimeError: this optimum's verdict failed" in failed.message
    assert_chunk(results[:1] + [oracles[1]] + results[2:], oracles)


@pytest.mark.parametrize("timeout", [None, 60])
def test_a_chunk_ends_with_the_item_that_spends_its_budget(shipped, timeout):
    digest, base = shipped
    items, oracles = items_and_oracles(base)
    for budget, count in ((1e-9, 1), (1e3, len(items))):
        results, seconds = tasks.optimize_chunk(digest, items, OPTIONS, {}, timeout, budget)
        assert len(results) == len(seconds) == count
        assert_same(results[0], oracles[0])



def test_each_item_is_charged_its_solve_and_an_equal_share_of_the_verdicts(shipped, monkeypatch):
    """Without a timeout an item's seconds are its own solve's CPU seconds plus the
    verdicts' CPU seconds over the items (docs/batch.md): the chunk's CPU time is charged
    in full, none twice. The solves' seconds and the process clock read around the
    verdicts are set here, so that the sums are known."""
    digest, base = shipped
    items, _ = items_and_oracles(base)
    solves = [0.25 * (k + 1) for k in range(len(items))]
    real_in_turn = tasks.in_turn

    def in_turn(kind, calls, timeout, budget):
        results, seconds = real_in_turn(kind, calls, timeout, budget)
        assert len(seconds) == len(solves)
        return results, list(solves)
    clock = iter([40.0, 40.0 + 2.1])        # before and after the verdicts, read once each
    monkeypatch.setattr(tasks, "in_turn", in_turn)
    monkeypatch.setattr(tasks, "time", type("Clock", (), {"process_time": staticmethod(lambda: next(clock))}))
    results, seconds = tasks.optimize_chunk(digest, items, OPTIONS, {}, None)
    assert len(results) == len(items)
    np.testing.assert_allclose(seconds, [s + 2.1 / len(items) for s in solves], rtol=1e-13)
    assert sum(seconds) == pytest.approx(sum(solves) + 2.1, rel=1e-13)
