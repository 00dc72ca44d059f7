"""simulate() checks its arguments: one bad argument at a time (shapes, non-finite, ragged,
symbolic, complex or non-numeric values, variants, rules, steps, step sizes, solver
options, start velocities outside the allowed set), and the error names it.
Oracle: the messages, checked by content (the argument they must name)."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.systems import knife_edge

from tests._helpers import GOOD


def simulate_with(disc, **changes):
    """simulate() on valid knife-edge data with some arguments replaced (None drops one)."""
    kwargs = {**GOOD, **changes}
    return dmoc.simulate(disc, **{k: v for k, v in kwargs.items() if v is not None})


def test_good_data_runs(disc):
    """The baseline of the error tests below is valid: each test changes one thing."""
    assert simulate_with(disc).success


@pytest.mark.parametrize("name, value", [
    ("q0", [0.0, 0.0]),
    ("q0", [[0.0, 0.0, 0.3]]),
    ("q0", [0.0, 0.0, 0.3, 1.0]),
    ("v0", [1.0, 0.0]),
    ("v0", np.zeros((3, 1))),
    ("controls", np.zeros((4, 2))),        # steps = 5
    ("controls", np.zeros((5, 3))),        # n_u = 2
    ("controls", np.zeros(10)),
])
def test_wrong_shapes(disc, name, value):
    with pytest.raises(ValueError, match=f"`{name}`.*shape"):
        simulate_with(disc, **{name: value})


def test_wrong_shape_of_p0(disc):
    with pytest.raises(ValueError, match="`p0`.*shape"):
        simulate_with(disc, v0=None, p0=[1.0, 0.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("name", ["q0", "v0", "p0", "controls"])
def test_non_finite_values(disc, name, bad):
    good = {"q0": GOOD["q0"], "v0": GOOD["v0"], "p0": [1.0, 0.0, 1.0],
            "controls": np.zeros((5, 2))}[name]
    value = np.array(good, dtype=float)
    value.flat[1] = bad
    changes = {name: value}
    if name == "p0":
        changes["v0"] = None
    with pytest.raises(ValueError, match=f"`{name}` must be finite"):
        simulate_with(disc, **changes)


def test_non_numeric_q0(disc):
    with pytest.raises(TypeError, match="`q0`"):
        simulate_with(disc, q0="abc")


@pytest.mark.parametrize("variant", ["x", "plus", None, 1])
def test_unknown_variant(disc, variant):
    with pytest.raises(ValueError, match=r"`variant` must be one of '\+', '-'"):
        dmoc.simulate(disc, **GOOD, variant=variant)
    with pytest.raises(ValueError, match="`variant`"):
        dmoc.StepResidual(disc, variant)


@pytest.mark.parametrize("rule", ["euler", "Midpoint", None, 2])
def test_unknown_rule(rule):
    with pytest.raises(ValueError, match="`rule` must be one of 'midpoint', 'trapezoid'"):
        dmoc.discretize(knife_edge(), 0.1, rule)


def test_both_or_neither_of_v0_p0(disc):
    with pytest.raises(ValueError, match="exactly one of `v0`.*`p0`"):
        simulate_with(disc, p0=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="exactly one of `v0`.*`p0`"):
        simulate_with(disc, v0=None)


@pytest.mark.parametrize("steps", [0, -3, 2.5, 5.0, "5", True])
def test_bad_steps(disc, steps):
    with pytest.raises(ValueError, match="`steps` must be a positive integer"):
        simulate_with(disc, steps=steps)


def test_numpy_integer_steps_accepted(disc):
    assert simulate_with(disc, steps=np.int64(3)).trajectory.steps == 3


@pytest.mark.parametrize("h", [0.0, -0.1, np.nan, np.inf])
def test_bad_step_size(h):
    with pytest.raises(ValueError, match="`h` must be finite and positive"):
        dmoc.discretize(knife_edge(), h)


def test_non_numeric_step_size():
    with pytest.raises(TypeError, match="`h` must be a real number"):
        dmoc.discretize(knife_edge(), "0.1")


@pytest.mark.parametrize("name, value", [("tol", 0.0), ("tol", np.nan), ("max_iter", 0),
                                         ("max_iter", 1.5)])
def test_bad_solver_options(disc, name, value):
    with pytest.raises(ValueError, match=f"`{name}`"):
        simulate_with(disc, **{name: value})


def test_wrong_object_types(disc):
    with pytest.raises(TypeError, match="`disc` must be a Discretization"):
        dmoc.simulate(knife_edge(), **GOOD)
    with pytest.raises(TypeError, match="`system` must be a MechanicalSystem"):
        dmoc.discretize("knife", 0.1)


@pytest.mark.parametrize("v0", [[0.0, 1.0, 0.0], [np.cos(0.3), np.sin(0.3) + 1e-6, 1.0]])
def test_v0_violating_the_constraint(disc, v0):
    """A(q0) v0 != 0: sideways velocity (one of them only 1e-6 off)."""
    with pytest.raises(ValueError, match="`v0` violates the velocity constraints"):
        simulate_with(disc, v0=v0)


def test_ragged_controls_are_named(disc):
    with pytest.raises(dmoc.InputError, match="`controls` .*ragged"):
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=3, controls=[[0, 0], [0], [0, 0]])


def test_symbolic_start_is_named(disc):
    with pytest.raises(dmoc.InputTypeError, match="`q0` .*symbolic SX.*evaluate"):
        dmoc.simulate(disc, q0=ca.SX.sym("q", 3), v0=[1, 0, 0], steps=3)


def test_complex_start_is_refused(disc):
    with pytest.raises(dmoc.InputTypeError, match="`q0` .*complex128"):
        dmoc.simulate(disc, q0=[0, 0, 1j], v0=[1, 0, 0], steps=3)


@pytest.mark.parametrize("value", [["0", "0", "0"], [True, False, True]])
def test_numbers_only(disc, value):
    with pytest.raises(TypeError, match="`q0`"):
        dmoc.simulate(disc, q0=value, v0=[1, 0, 0], steps=2)


def test_ragged_controls_with_lobatto():
    disc = dmoc.discretize(knife_edge(), 0.1, "lobatto3")
    with pytest.raises(dmoc.InputError, match="`controls`.*ragged"):
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=3, controls=[[0, 0], [0], [0, 0]])
