"""The NLP expanded to SX (``expand=True``) or compiled to C (``jit=True``,
`dmoc.optimal_control.nlp.evaluation`) is the same NLP: IPOPT takes the same iterations to the same
optimum, bit for bit, as with CasADi's virtual machine on the MX graph, first solves and
warm re-solves alike, on both problems of the rockit comparison and with both stage rules,
and an MPC's closed loop (`dmoc.MPC(..., expand=, jit=)`) step by step;
IPOPT really evaluates the flat or compiled Functions (not the MX graph); the compiled
library lives in the private compiled-code cache and is loaded, not compiled, by a later
process. Bad input is named.

Oracle: the virtual machine's solve of the same problem (a separate evaluation path: the
assembled MX Functions interpreted by CasADi rather than flattened or compiled)."""

import os
import subprocess
import sys

import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc._util import compiled
from dmoc.errors import InputError, InputTypeError
from dmoc.optimal_control.nlp import evaluation
from dmoc.optimal_control.solver.ipopt import solver, start_options
from dmoc.optimal_control import solve

needs_compiler = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")

PROBLEMS = {"knife edge": (dmoc.problems.knife_edge_parking, [0.05, 1.05, 0.05]),
            "rolling disk": (dmoc.problems.rolling_disk_steering, [1.05, 1.0, None, 1.6])}


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    """An empty compiled-code folder of this test's own, and no compiled NLP in memory."""
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path))
    dmoc.clear_caches("compiled_nlps", "expanded_nlps", "row_sums", "solvers")
    yield tmp_path
    dmoc.clear_caches("compiled_nlps", "expanded_nlps", "row_sums", "solvers")


MODES = {"expand": {"expand": True},
         "jit": pytest.param({"jit": True}, marks=needs_compiler)}


@pytest.mark.parametrize("mode", MODES.values(), ids=MODES.keys())
@pytest.mark.parametrize("rule", ["lobatto3", "lobatto4"])
@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_flat_and_compiled_nlps_give_the_same_solves_bit_for_bit(private_cache, name, rule, mode):
    make, neighbour = PROBLEMS[name]
    problem = make(12, rule=rule)
    moved = problem.with_boundary(q_goal=neighbour)
    runs = []
    for switches in ({}, mode):
        first = solve(problem, **switches)
        runs.append((first, solve(moved, guess=first, **switches)))
    for vm, other in zip(*runs):
        assert other.stats["iterations"] == vm.stats["iterations"] > 0
        assert other.cost == vm.cost
        for field in ("x", "lam_x", "lam_g"):
            np.testing.assert_array_equal(getattr(other, field), getattr(vm, field))
    assert runs[1][1].stats["warm_start"]
    assert len(list(private_cache.glob("dmoc_nlp-*.so"))) == (1 if "jit" in mode else 0)


@pytest.mark.parametrize("mode, kind", [({"jit": False, "expand": False}, "MXFunction"),
                                        ({"jit": False, "expand": True}, "SXFunction"),
                                        pytest.param({"jit": True, "expand": False}, "External",
                                                     marks=needs_compiler)])
def test_ipopt_evaluates_the_functions_of_the_mode(private_cache, mode, kind):
    problem = dmoc.problems.knife_edge_parking(8, rule="lobatto3")
    packed = solver(problem.transcription, {}, reuse=True, report=False, **mode)[0]
    for name in ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l"):
        assert packed.nlpsol.get_function(name).class_name() == kind


@needs_compiler
def test_a_compiled_solver_is_shared_whatever_expand_says(private_cache):
    problem = dmoc.problems.knife_edge_parking(8, rule="lobatto3")
    first = solver(problem.transcription, {}, reuse=True, report=False, jit=True, expand=False)[0]
    again, reused, _ = solver(problem.transcription, {}, reuse=True, report=False, jit=True, expand=True)
    assert reused and again is first
    flat, reused, _ = solver(problem.transcription, {}, reuse=True, report=False, jit=False, expand=True)
    assert not reused and flat is not first


def closed_loop(steps, **switches):
    """(the records of `steps` MPC steps on knife-edge parking against a 10 % heavier plant
    kicked at step 2: (applied u, plan's x, lam_x, lam_g, iterations) per step; the MPC)."""
    problem = dmoc.problems.knife_edge_parking(10, duration=1.0)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1), problem.disc.h)
    controller = dmoc.MPC(problem, **switches)
    q, p, records = np.zeros(3), np.zeros(3), []
    for k in range(steps):
        u = controller.step(q, p=p)
        plan = controller.plan
        records.append((u, plan.x, plan.lam_x, plan.lam_g, plan.stats["iterations"]))
        p = p + (0.3 if k == 2 else 0.0) * np.array([np.cos(q[2]), np.sin(q[2]), 1.0])
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
    return records, controller


MPC_MODES = {"default": {}, "expand": {"expand": True},
             "jit": pytest.param({"jit": True}, marks=needs_compiler)}


@pytest.mark.parametrize("mode", MPC_MODES.values(), ids=MPC_MODES.keys())
def test_the_mpc_closed_loop_is_the_same_bit_for_bit(private_cache, mode):
    """The MPC's default (expanded) and its compiled evaluations against the MX graph
    (``expand=False``), step by step."""
    (vm, _), (other, controller) = closed_loop(5, expand=False), closed_loop(5, **mode)
    assert [r.warm_start for r in controller.log] == [False] + [True] * 4
    kept, reused, _ = solver(controller.problem.transcription, start_options(True),
                             reuse=True, report=False, **{"expand": True, "jit": False, **mode})
    assert reused and kept.nlpsol.get_function("nlp_jac_g").class_name() == (
        "External" if "jit" in mode else "SXFunction")
    for a, b in zip(vm, other):
        for x, y in zip(a[:4], b[:4]):
            np.testing.assert_array_equal(y, x)
        assert b[4] == a[4] > 0
    assert len(list(private_cache.glob("dmoc_nlp-*.so"))) == (1 if "jit" in mode else 0)


def test_the_mpc_refuses_a_switch_that_is_not_a_bool():
    with pytest.raises(InputTypeError, match="`jit` must be True or False"):
        dmoc.MPC(dmoc.problems.knife_edge_parking(8), jit=1)
    with pytest.raises(InputTypeError, match="`expand` must be True or False"):
        dmoc.MPC(dmoc.problems.knife_edge_parking(8), expand="no")


CHILD = """
import dmoc.problems
from dmoc._util.compiled import Library
from dmoc.optimal_control import solve
problem = dmoc.problems.knife_edge_parking(8, rule="lobatto3")
functions = problem.transcription.separable.functions().values()
cached = Library(functions, "dmoc_nlp").cached()
print(cached, solve(problem, jit=True).cost)
"""


@needs_compiler
def test_a_later_process_loads_the_library_without_compiling(private_cache):
    """The library's key is the same in every process (the Functions serialize alike), so
    the second process finds the first one's library and loads it as it is."""
    env = {**os.environ, "DMOC_CACHE_DIR": str(private_cache)}

    def child():
        return subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                              text=True, check=True).stdout.split()
    first = child()
    libraries = list(private_cache.glob("dmoc_nlp-*.so"))
    stamp = libraries[0].stat().st_mtime_ns
    second = child()
    assert (first[0], second[0]) == ("False", "True")
    assert list(private_cache.glob("dmoc_nlp-*.so")) == libraries
    assert libraries[0].stat().st_mtime_ns == stamp              # loaded, not compiled again
    assert first[1] == second[1]


def test_jit_without_a_compiler_is_named(private_cache, monkeypatch):
    monkeypatch.setattr(evaluation, "compiler", lambda: None)
    with pytest.raises(InputError, match="`jit=True` needs a C compiler"):
        dmoc.optimize(dmoc.problems.knife_edge_parking(8), jit=True)


def test_jit_must_be_a_bool():
    with pytest.raises(InputTypeError, match="jit"):
        solve(dmoc.problems.knife_edge_parking(8), jit="yes")
