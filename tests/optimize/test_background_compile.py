"""The default ``jit=None`` of the solve (`dmoc.optimal_control.nlp.evaluation.compiled_when_ready`): a
structure's NLP is compiled in a background thread once it is re-solved, and the re-solves
after its library is loaded evaluate the compiled Functions, with the iterations and the
optimum, bit for bit, of the virtual machine's re-solve from the same start; a first solve
never compiles, nor does any solve without a C compiler or with ``jit=False``.

Oracle: the virtual machine's re-solve (``jit=False``) from the same guess."""

import time

import numpy as np
import pytest

import dmoc
from dmoc._util import compiled
from dmoc.optimal_control import solve
from dmoc.optimal_control.nlp import evaluation
from dmoc.problems import knife_edge_parking

needs_compiler = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    """An empty compiled-code folder of this test's own, and no compiled NLP in memory."""
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path))
    names = ("compiled_nlps", "background_compiles", "solvers", "row_sums")
    dmoc.clear_caches(*names)
    yield tmp_path
    dmoc.clear_caches(*names)


def re_solves(problem, first, until, seconds=120.0, **keywords):
    """(the guess, the re-solve from it) of the first warm re-solve of `problem` at goals
    near its own, in a cycle from `first`, for which ``until(result)`` holds; fails after
    `seconds`."""
    deadline, previous = time.monotonic() + seconds, first
    for k in range(100_000):
        result = solve(problem.with_boundary(q_goal=[0.0, 1.0 + 0.01 * (k % 3), 0.0]),
                               guess=previous, **keywords)
        assert result.stats["warm_start"]
        if until(result):
            return previous, result
        assert time.monotonic() < deadline, "the background compile did not end"
        previous = result
        time.sleep(0.01)


@needs_compiler
def test_a_re_solved_structure_switches_to_its_compiled_nlp_with_the_same_bits(private_cache):
    problem = knife_edge_parking(6)
    first = solve(problem)
    assert first.stats["compiled"] is False          # a first solve does not compile
    guess, result = re_solves(problem, first, lambda r: r.stats["compiled"])
    oracle = solve(result_problem(problem, result), guess=guess, jit=False)
    assert oracle.stats["compiled"] is False
    assert result.stats["iterations"] == oracle.stats["iterations"]
    assert np.array_equal(result.x, oracle.x) and np.array_equal(result.lam_g, oracle.lam_g)
    assert len(list(private_cache.glob("dmoc_nlp-*.so"))) == 1


def result_problem(problem, result):
    """`problem` with the goal `result` reached (its last knot)."""
    return problem.with_boundary(q_goal=result.trajectory.q[-1].tolist())


@pytest.mark.parametrize("how", ["no compiler", "jit=False"])
def test_without_a_compiler_or_with_jit_false_nothing_is_compiled(private_cache, monkeypatch, how):
    problem = knife_edge_parking(6)
    keywords = {"jit": False} if how == "jit=False" else {}
    if how == "no compiler":
        monkeypatch.setattr(evaluation, "compiler", lambda: None)
    previous = solve(problem, **keywords)
    for goal in (1.01, 1.02, 1.03):
        previous = solve(problem.with_boundary(q_goal=[0.0, goal, 0.0]), guess=previous, **keywords)
        assert previous.stats["warm_start"] and previous.stats["compiled"] is False
    assert len(evaluation._BACKGROUND) == 0
    assert not list(private_cache.glob("dmoc_nlp-*.so"))
