"""The simulator's compiled C step (dmoc._util.compiled, cached on disk) gives what
CasADi's virtual machine gives, bit for bit; the default switches to it mid-run and falls
back with a warning when no compiler works or no working directory exists. Iteration
counts and identities only, no timing."""

import os
import shutil
import tempfile

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc._util import compiled
from dmoc.simulation import stepper as stepper_module
from dmoc.systems import knife_edge


CASES = {
    "inclined knife edge": (lambda: dmoc.systems.knife_edge(incline=0.2), [0, 0, 0.1],
                            [np.cos(0.1), np.sin(0.1), 1.0]),
    "rolling disk": (dmoc.systems.rolling_disk, [0, 0, 0, 0], [1.0, 0.0, 1.0, 0.5]),
}


@pytest.fixture
def fresh_steppers(monkeypatch, tmp_path):
    """An empty stepper cache and an empty on-disk cache directory for this test."""
    dmoc.clear_caches("steppers")
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path))
    yield tmp_path
    dmoc.clear_caches("steppers")


def _run(disc, q0, v0, variant, jit, steps=300):
    controls = np.column_stack([np.sin(0.02 * np.arange(steps)), np.ones(steps)])
    return dmoc.simulate(disc, q0=q0, v0=v0, steps=steps, controls=controls, variant=variant, jit=jit)


needs_compiler = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")


@needs_compiler
@pytest.mark.parametrize("name", CASES)
def test_compiled_step_is_bit_identical_to_the_virtual_machine(fresh_steppers, name):
    """The compiled library computes, bit for bit, what the virtual machine computes with
    the same Functions (jit=None before anything is compiled or cached); jit=False's lighter
    Functions (no common-subexpression elimination) agree to round-off."""
    make, q0, v0 = CASES[name]
    disc = dmoc.discretize(make(), 0.02)
    for variant in ("+", "-"):
        vm, native, light = (_run(disc, q0, v0, variant, jit) for jit in (None, True, False))
        assert [r.stats["native"] for r in (vm, native, light)] == [False, True, False]
        for field in ("q", "p", "lam", "mu"):
            np.testing.assert_array_equal(getattr(vm.trajectory, field), getattr(native.trajectory, field))
            a, b = getattr(light.trajectory, field), getattr(native.trajectory, field)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * (1 + np.abs(b).max(initial=0)))
        assert vm.stats["max_residual"] == native.stats["max_residual"] < 1e-12
    assert len(list(fresh_steppers.glob("dirac_step-*.so"))) == 2      # one library per variant


@needs_compiler
def test_library_is_reused_from_disk_and_default_loads_it(fresh_steppers, monkeypatch):
    make, q0, v0 = CASES["inclined knife edge"]
    disc = dmoc.discretize(make(), 0.02)
    assert _run(disc, q0, v0, "+", None).stats["native"] is False     # not cached, not long yet
    first = _run(disc, q0, v0, "+", True)
    (library,) = fresh_steppers.glob("dirac_step-*.so")
    stamp = library.stat().st_mtime_ns
    dmoc.clear_caches("steppers")     # a "new process"
    again = _run(disc, q0, v0, "+", None)
    assert again.stats["native"] is True and library.stat().st_mtime_ns == stamp
    np.testing.assert_array_equal(again.trajectory.q, first.trajectory.q)


@needs_compiler
def test_default_switches_to_compiled_code_mid_run(fresh_steppers, monkeypatch):
    """The default run that compiles mid-run equals, bit for bit, one that stays in the
    virtual machine with the same Functions (the default's, before anything is compiled)."""
    make, q0, v0 = CASES["rolling disk"]
    disc = dmoc.discretize(make(), 0.02)
    monkeypatch.setattr(stepper_module, "NATIVE_AFTER_SECONDS", float("inf"))
    vm = _run(disc, q0, v0, "+", None, steps=3000)
    dmoc.clear_caches("steppers")
    monkeypatch.setattr(stepper_module, "NATIVE_AFTER_SECONDS", 0.0)
    switched = _run(disc, q0, v0, "+", None, steps=3000)
    assert (vm.stats["native"], switched.stats["native"]) == (False, True)
    np.testing.assert_array_equal(switched.trajectory.q, vm.trajectory.q)


def test_without_a_compiler_the_default_falls_back_and_jit_true_says_why(fresh_steppers, monkeypatch):
    monkeypatch.setenv("CC", "")
    assert compiled.compiler() is None
    make, q0, v0 = CASES["inclined knife edge"]
    disc = dmoc.discretize(make(), 0.02)
    result = _run(disc, q0, v0, "+", None)
    assert result.success and result.stats["native"] is False
    assert result.stats["max_residual"] < 1e-12
    with pytest.raises(ValueError, match="C compiler"):
        _run(disc, q0, v0, "+", True)
    assert not list(fresh_steppers.glob("*.so"))


@pytest.mark.skipif(not shutil.which("false"), reason="no `false` command")
def test_a_failing_compiler_warns_and_falls_back(fresh_steppers, monkeypatch):
    monkeypatch.setenv("CC", "false")                  # a "compiler" that always fails
    monkeypatch.setattr(stepper_module, "NATIVE_AFTER_SECONDS", 0.0)
    make, q0, v0 = CASES["inclined knife edge"]
    disc = dmoc.discretize(make(), 0.02)
    with pytest.warns(RuntimeWarning, match="virtual machine instead"):
        result = _run(disc, q0, v0, "+", None)
    assert result.success and result.stats["native"] is False
    with pytest.raises(RuntimeError, match="compiling"):
        _run(disc, q0, v0, "+", True)


def test_jit_without_a_usable_working_directory():
    here = os.getcwd()
    gone = tempfile.mkdtemp()
    os.chdir(gone)
    os.rmdir(gone)
    try:
        result = dmoc.simulate(dmoc.discretize(knife_edge(mass=1.9), 0.1), q0=[0, 0, 0],
                               v0=[1, 0, 1], steps=3, jit=True)
    finally:
        os.chdir(here)
    assert result.success


@pytest.mark.parametrize("change", ["casadi version", "compiler", "flags", "function"])
def test_library_key_changes_with_what_the_code_depends_on(monkeypatch, tmp_path, change):
    """The library's file is named by what its machine code depends on: the serialized
    Functions, the CasADi version (the generated C and its runtime), the compiler and its
    flags. Changing any one of them gives another key (so another file name), so a stale
    library is never loaded; the same inputs give the same key. No compile runs here: the
    key is computed before anything is compiled."""
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compiled, "compiler", lambda: "/usr/bin/cc")
    x = ca.SX.sym("x")
    functions = [ca.Function("double", [x], [2 * x])]
    before = compiled.Library(functions, "step").key
    assert compiled.Library(functions, "step").key == before
    if change == "casadi version":
        monkeypatch.setattr(ca, "__version__", ca.__version__ + ".1")
    elif change == "compiler":
        monkeypatch.setattr(compiled, "compiler", lambda: "/usr/bin/gcc")
    elif change == "flags":
        monkeypatch.setattr(compiled, "FLAGS", compiled.FLAGS + ("-march=native",))
    else:
        functions = [ca.Function("double", [x], [3 * x])]
    after = compiled.Library(functions, "step").key
    assert after != before
