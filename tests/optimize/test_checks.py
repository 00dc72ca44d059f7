"""OptimalControlProblem checks the user's statement: only None leaves boundary data free
(NaN, bools and strings are refused), bounds of the wrong kind or on the wrong side, free
symbols in the callables and boundary data outside the bounds are named.
Oracle: the messages, checked by content (the argument they must name)."""

import casadi as ca
import numpy as np
import pytest

import dmoc

from tests._helpers import problem


@pytest.mark.parametrize("name", ["q_goal", "q_start", "v_goal", "v_start"])
@pytest.mark.parametrize("entry, error, words", [
    (np.nan, dmoc.InputError, "NaN; only None leaves an entry free"),
    (True, dmoc.InputTypeError, "entry 1 is True"),
    ("0.5", dmoc.InputTypeError, "entry 1 is '0.5'"),
    (np.float32("nan"), dmoc.InputError, "NaN; only None leaves an entry free"),
    (1j, dmoc.InputTypeError, "entry 1 is 1j"),
    (np.bool_(False), dmoc.InputTypeError, "entry 1 is (np.)?False"),
    (10 ** 400, dmoc.InputError, "entry 1 is too large for a float"),
    (np.inf, dmoc.InputError, r"must be finite; entry \(1,\) is inf"),
    (-np.inf, dmoc.InputError, r"must be finite; entry \(1,\) is -inf"),
    (np.array([0.2]), dmoc.InputTypeError, r"entry 1 is array\(\[0.2\]\)"),     # not NumPy's ragged-array error
    ([0.2, 0.3], dmoc.InputTypeError, r"entry 1 is \[0.2, 0.3\]"),
])
def test_only_none_is_free_in_boundary_data(disc, name, entry, error, words):
    data = {"q_start": [0.0, 0.0, 0.0], "q_goal": [0.0, 1.0, 0.0]}
    data[name] = [0.0, entry, 0.0]
    with pytest.raises(error, match=f"`{name}`.*{words}"):
        dmoc.OptimalControlProblem(disc, 5, **data)


def test_bounds_refuse_nan_and_bools(disc):
    with pytest.raises(dmoc.InputTypeError, match="`control_bounds`.*True"):
        dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                   control_bounds=([True, 0.0], [1.0, 1.0]))


def test_none_still_means_free(disc):
    problem = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0], q_goal=[0, 1, None])
    assert np.isnan(problem.q_goal[2]) and np.isfinite(problem.q_goal[:2]).all()


@pytest.mark.parametrize("entry", [2, np.int64(2), np.float32(0.1), np.float64(0.1), 0.1,
                                   __import__("fractions").Fraction(1, 3)])
def test_boundary_entries_read_as_floats(disc, entry):
    """Every kind of real number is read as `float(entry)` would read it."""
    problem = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0], q_goal=[entry, 1, None])
    assert problem.q_goal.dtype == float and problem.q_goal[0] == float(entry)


@pytest.mark.parametrize("bounds", [([np.inf] * 2, [np.inf] * 2), ([-np.inf] * 2, [-np.inf] * 2)])
def test_infinite_bounds_on_the_wrong_side(disc, bounds):
    with pytest.raises(ValueError, match="`control_bounds`"):
        problem(disc, control_bounds=bounds)


def test_ocp_names_free_symbols_and_boundary_outside_bounds(disc):
    stray = ca.SX.sym("stray")
    base = dict(q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(ValueError, match="`running_cost` uses symbols"):
        dmoc.OptimalControlProblem(disc, 10, running_cost=lambda q, v, u: stray * ca.sumsqr(u), **base)
    with pytest.raises(ValueError, match="`path_constraints` uses symbols"):
        dmoc.OptimalControlProblem(disc, 10, path_constraints=lambda q, v, u: q[0] - stray, **base)
    with pytest.raises(ValueError, match="`q_goal` must lie within `state_bounds`"):
        dmoc.OptimalControlProblem(disc, 10, state_bounds=([-1, -1, -1], [1, 0.5, 1]), **base)


@pytest.mark.parametrize("change, words", [
    ({"q_start": [0.0, 2.0, 0.0]}, r"`q_start` must lie within `state_bounds`; q_start\[1\] \(y\) = 2 > 1.5\."),
    ({"q_goal": [0.0, -2.0, -3.0]}, r"`q_goal` must lie within `state_bounds`; q_goal\[1\] \(y\) = -2 < -1, "
                                    r"q_goal\[2\] \(theta\) = -3 < -1\."),
    ({"v_goal": [0.0, 1.0, 0.0]}, "`v_goal` violates the velocity constraints"),
    ({"v_start": [1.0, 1.0, 0.0], "q_start": [0.0, 0.0, 0.0]}, "`v_start` violates the velocity constraints"),
    ({"v_start": [0.0, 0.0, 0.0], "p_start": [0.0, 0.0, 0.0]}, "not both"),
    ({"p_start": [0.0, np.nan, 0.0]}, "`p_start`"),
    ({"q_start": [0.0, 0.0]}, r"`q_start` must have shape \(3,\)"),
])
def test_with_boundary_checks_the_data_it_changes(disc, change, words):
    """`with_boundary` checks only the ends whose data change, but those as the constructor
    does (the data of a fully given end against its velocity constraints, both ends
    against the state bounds)."""
    base = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                      state_bounds=([-1, -1, -1], [1, 1.5, 1]))
    with pytest.raises(dmoc.InputError, match=words):
        base.with_boundary(**change)
