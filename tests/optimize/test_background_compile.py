"""The default ``jit=None`` of the solve (`dmoc.optimal_control.nlp.evaluation.compiled_when_ready`):
a structure's NLP is compiled in a background thread once its warm re-solves have spent
COMPILE_AFTER_SECONDS in IPOPT, and its solves after the library is loaded (cold ones too)
evaluate the compiled Functions, with the iterations and the optimum, bit for bit, of the
virtual machine's re-solve from the same start; a few re-solves start no compiler, nor
does any solve without a C compiler or with ``jit=False``.

Oracles: the virtual machine's re-solve (``jit=False``) from the same guess; the sum of
the re-solves' own ``stats["ipopt_time"]``."""

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
    names = ("compiled_nlps", "background_compiles", "re_solve_seconds", "solvers", "row_sums")
    dmoc.clear_caches(*names)
    yield tmp_path
    dmoc.clear_caches(*names)


def goal(k):
    return [0.0, 1.0 + 0.01 * (k % 3), 0.0]


@needs_compiler
def test_a_re_solved_structure_switches_to_its_compiled_nlp_with_the_same_bits(private_cache, monkeypatch):
    monkeypatch.setattr(evaluation, "COMPILE_AFTER_SECONDS", 0.0)   # from the first re-solve on
    problem = knife_edge_parking(6)
    previous = solve(problem)
    assert previous.stats["compiled"] is False          # a first solve does not compile
    deadline = time.monotonic() + 120
    for k in range(100_000):
        result = solve(problem.with_boundary(q_goal=goal(k)), guess=previous)
        if result.stats["compiled"]:
            break
        assert time.monotonic() < deadline, "the background compile did not end"
        previous = result
        time.sleep(0.01)
    oracle = solve(problem.with_boundary(q_goal=goal(k)), guess=previous, jit=False)
    assert oracle.stats["compiled"] is False
    assert result.stats["iterations"] == oracle.stats["iterations"]
    assert np.array_equal(result.x, oracle.x) and np.array_equal(result.lam_g, oracle.lam_g)
    assert solve(problem).stats["compiled"]             # loaded: a cold solve takes it too
    assert len(list(private_cache.glob("dmoc_nlp-*.so"))) == 1


def test_a_few_re_solves_start_no_compiler(private_cache):
    """Three re-solves of a few ms each stay below COMPILE_AFTER_SECONDS (0.1 s): what they
    spent in IPOPT or in Newton's method is counted, and nothing is compiled."""
    problem = knife_edge_parking(6)
    previous, seconds = solve(problem), 0.0
    for k in range(3):
        previous = solve(problem.with_boundary(q_goal=goal(k)), guess=previous)
        seconds += previous.stats["newton_time" if previous.stats["nlp_solver"] == "newton" else "ipopt_time"]
        assert previous.stats["warm_start"] and not previous.stats["compiled"]
    assert seconds < evaluation.COMPILE_AFTER_SECONDS
    assert evaluation._SPENT.get(problem.transcription.separable.key, list)[0] == pytest.approx(seconds, rel=1e-12)
    assert len(evaluation._BACKGROUND) == 0 and not list(private_cache.glob("dmoc_nlp-*.so"))


@pytest.mark.parametrize("how", ["no compiler", "jit=False"])
def test_without_a_compiler_or_with_jit_false_nothing_is_compiled(private_cache, monkeypatch, how):
    monkeypatch.setattr(evaluation, "COMPILE_AFTER_SECONDS", 0.0)
    problem = knife_edge_parking(6)
    keywords = {"jit": False} if how == "jit=False" else {}
    if how == "no compiler":
        monkeypatch.setattr(evaluation, "compiler", lambda: None)
    previous = solve(problem, **keywords)
    for k in range(3):
        previous = solve(problem.with_boundary(q_goal=goal(k)), guess=previous, **keywords)
        assert previous.stats["warm_start"] and previous.stats["compiled"] is False
    assert len(evaluation._BACKGROUND) == 0
    assert not list(private_cache.glob("dmoc_nlp-*.so"))
