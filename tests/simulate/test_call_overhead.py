"""What `simulate` does on every call, made cheaper (benchmarks/batch.py, the simulate
rows), computes the same bits: its trajectory is what the checking
constructor ``Trajectory(...)`` makes of the same fields; the start momentum and the
constraint checks through `Evaluator` equal CasADi's own calls; the compiler found once
per process is found again when the compiler changes."""

import os

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc._util.numeric import Evaluator
from dmoc.principle.trajectory import Trajectory
from dmoc._util import compiled

FIELDS = ("t", "q", "p", "lam", "u", "mu", "s")

SYSTEMS = {
    "knife edge": (dmoc.systems.knife_edge, [0.1, 0.2, 0.3], [np.cos(0.3), np.sin(0.3), 1.0]),
    "rolling disk": (dmoc.systems.rolling_disk, [0, 0, 0, 0], [1.0, 0.0, 1.0, 0.5]),
}


def _same(traj, other):
    """Every field of two Trajectories equal bit for bit, with the same types and shapes."""
    for name in FIELDS:
        a, b = getattr(traj, name), getattr(other, name)
        assert type(a) is np.ndarray and a.dtype == b.dtype == float, name
        assert a.shape == b.shape and a.tobytes() == b.tobytes(), name
        assert a.flags.c_contiguous and a.flags.owndata, name     # copies, as Trajectory makes
    for name in ("h", "variant", "control_nodes", "stage_nodes"):
        a, b = getattr(traj, name), getattr(other, name)
        assert type(a) is type(b) and a == b, name
    assert all(type(c) is float for c in (*traj.control_nodes, *traj.stage_nodes))


def _checked(traj):
    """The Trajectory the checking constructor makes of the fields of `traj`."""
    return Trajectory(*(getattr(traj, name) for name in ("t", "q", "p", "lam", "u", "h", "variant",
                                                         "mu", "s", "control_nodes", "stage_nodes")))


@pytest.mark.parametrize("system", SYSTEMS)
@pytest.mark.parametrize("rule", ["midpoint", "trapezoid", "lobatto4"])
@pytest.mark.parametrize("variant", ["+", "-"])
def test_the_trajectory_is_what_the_checking_constructor_makes_of_it(system, rule, variant):
    make, q0, v0 = SYSTEMS[system]
    disc = dmoc.discretize(make(), 0.05, rule=rule)
    traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=23, variant=variant, jit=False).trajectory
    _same(traj, _checked(traj))


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("failing", [0, 5])
def test_a_run_that_failed_at_once_or_later_keeps_checked_fields(variant, failing):
    """A huge control fails step `failing`: at 0 no step is kept (a (-) run has applied no
    impulse, so mu is zero)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    controls = np.zeros((9, 2))
    controls[failing] = 1e308          # overflows the step
    result = dmoc.simulate(disc, q0=[0, 0, 0.3], v0=[np.cos(0.3), np.sin(0.3), 1], steps=9,
                           controls=controls, variant=variant, throw=False, jit=False)
    assert not result.success and result.trajectory.steps == failing
    _same(result.trajectory, _checked(result.trajectory))
    mu = result.trajectory.mu
    assert mu.shape == (disc.system.m,) and (mu.any() == (variant == "-" and failing > 0))


@pytest.mark.parametrize("system", SYSTEMS)
def test_the_start_momentum_is_casadis_momentum_bit_for_bit(system):
    make, q0, v0 = SYSTEMS[system]
    sys = make()
    disc = dmoc.discretize(sys, 0.05)
    traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=3, jit=False).trajectory
    expected = np.array(sys.momentum(q0, v0)).ravel()       # CasADi's ordinary call
    assert traj.p[0].tobytes() == expected.tobytes()


def test_the_evaluator_equals_casadis_call_with_structural_zeros_and_shapes():
    x, y = ca.SX.sym("x", 3), ca.SX.sym("y", 2, 2)
    f = ca.Function("f", [x, y], [ca.vertcat(ca.horzcat(x[0], 0), ca.horzcat(0, ca.sin(x[2]))),
                                  x.T * y[1, 0], ca.mtimes(y, x[:2])])
    args = (np.array([0.3, -1.7, 2.9]), np.array([[1.5, -2.0], [0.25, 4.0]]))
    got = Evaluator(f)(args[0], args[1].ravel(order="F"))
    expected = [np.array(out) for out in f(*args)]
    assert [g.shape for g in got] == [(2, 2), (1, 3), (2, 1)]
    assert all(g.tobytes() == e.tobytes() for g, e in zip(got, expected))
    with pytest.raises(ValueError, match=r"`args\[1\]` must have 4 entries for 'f'; got 3"):
        Evaluator(f)(args[0], [1.0, 2.0, 3.0])
    sparse = ca.Function("g", [ca.SX.sym("x", ca.Sparsity.diag(2))], [ca.SX(1)])
    with pytest.raises(ValueError, match="'g' must have dense inputs; input 0 is sparse"):
        Evaluator(sparse)


def test_a_failed_evaluation_raises_as_casadis_call_does():
    """A Function whose evaluation fails (the sparse QR of a singular matrix) raises through
    the Evaluator as CasADi's ordinary call does, instead of returning the unwritten
    buffers."""
    A = ca.MX.sym("A", 3, 3)
    f = ca.Function("f", [A], [ca.solve(ca.mtimes(A, A.T), ca.DM.ones(3), "qr")])
    singular = np.array([[1.0, 2.0, 3.0]] * 3).ravel()
    with pytest.raises(RuntimeError, match="Evaluation failed"):
        f(singular.reshape(3, 3))
    with pytest.raises(RuntimeError, match="Evaluation failed"):
        Evaluator(f)(singular)
    np.testing.assert_allclose(Evaluator(f)(np.eye(3).ravel())[0], np.ones((3, 1)))


def test_the_evaluators_vector_call_equals_casadis_call_and_refuses_other_arrays():
    """`Evaluator.vector` (one input, one dense output, no conversions; the packed IPOPT
    call and the data's row sums use it): CasADi's own call gives the same bits, every
    entry (signed zeros, a subnormal, inf, NaN), on successive calls into new arrays; an
    array it would misread, a Function of two inputs and a sparse output are refused
    before the call."""
    x = ca.SX.sym("x", 5)
    f = ca.Function("f", [x], [ca.vertcat(x[0] * x[1], ca.sin(x[2]), 0, x[4] - x[3], x[2] / x[0])])
    for z in (np.array([0.0, -0.0, 5e-324, 1e308, -np.inf]), np.array([np.nan, 2.0, 0.5, 1.0, 3.0])):
        got = Evaluator(f).vector(z)
        assert got.tobytes() == np.array(f(z)).ravel().tobytes()
    evaluator = Evaluator(f)
    first, second = evaluator.vector(np.arange(5.0)), evaluator.vector(np.arange(5.0) + 1)
    assert first is not second and first[0] == 0.0 and second[0] == 2.0
    for bad in (np.arange(4.0), np.arange(5), np.arange(10.0)[::2], np.zeros((5, 1)), [0.0] * 5):
        with pytest.raises(ValueError, match="`vector` evaluates 'f' on a C-contiguous 1-d float array of 5"):
            evaluator.vector(bad)
    two = ca.Function("g", [x, ca.SX.sym("y")], [x[0]])
    sparse = ca.Function("h", [x], [ca.vertcat(x[0], ca.SX(1, 1))])
    for function in (two, sparse):
        with pytest.raises(ValueError, match="when it has one input and one dense output"):
            Evaluator(function).vector(np.zeros(5))


def test_only_an_interrupt_left_set_by_the_call_is_swallowed():
    """`_run`, the Evaluator's call of its buffer: a SystemError caused by a
    KeyboardInterrupt (what CasADi's check of Python's signals leaves set inside IPOPT's
    callbacks; the outputs are written) is swallowed; any other SystemError, and any other
    exception, reaches the caller as raised (the oracle: the errors raised here)."""
    from dmoc._util.numeric import _run

    def raising(error, cause):
        def run():
            raise error from cause
        return run
    failed = type("Buffer", (), {"ret": lambda self: 1})()     # a failed evaluation's return code
    assert _run(failed, raising(SystemError("left set"), KeyboardInterrupt())) is None
    for error, cause in ((SystemError("no cause"), None), (SystemError("other"), ValueError("v")),
                         (RuntimeError("casadi"), KeyboardInterrupt())):
        with pytest.raises(type(error)) as info:
            _run(failed, raising(error, cause))
        assert info.value is error


def _executable(path):
    path.write_text("#!/bin/sh\nexit 0\n")
    path.chmod(0o755)
    return path


def test_the_compiler_found_once_is_found_again_when_it_changes(tmp_path, monkeypatch):
    one, two = _executable(tmp_path / "one"), _executable(tmp_path / "two")
    link = tmp_path / "cc"
    link.symlink_to(one)
    monkeypatch.setenv("CC", str(link))
    assert compiled.compiler() == str(one)
    link.unlink()
    link.symlink_to(two)                          # the link moved to another compiler
    assert compiled.compiler() == str(two)
    link.unlink()                                 # no compiler any more
    assert compiled.compiler() is None
    monkeypatch.setenv("CC", "")
    assert compiled.compiler() is None
    monkeypatch.delenv("CC")
    monkeypatch.setenv("PATH", str(tmp_path))     # another PATH: looked up on it
    os.symlink(two, tmp_path / "gcc")
    assert compiled.compiler() == str(two)


def test_a_compiler_on_path_replaced_mid_process_is_looked_up_again(tmp_path, monkeypatch):
    """CC unset, `cc` found on PATH: replaced (renamed over, as an upgrade does) by a link
    to another compiler, the next call returns the new one's resolved path; one compiler
    found once is not found for good."""
    bin_folder, elsewhere = tmp_path / "bin", tmp_path / "elsewhere"
    bin_folder.mkdir()
    elsewhere.mkdir()
    cc, other = _executable(bin_folder / "cc"), _executable(elsewhere / "clang")
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(bin_folder))
    assert compiled.compiler() == str(cc)
    (tmp_path / "new").symlink_to(other)
    os.replace(tmp_path / "new", cc)
    assert compiled.compiler() == str(other)
