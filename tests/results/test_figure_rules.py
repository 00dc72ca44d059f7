"""The verdict's figures stated once (`dmoc.results.figure_rules`): each rule evaluated on
NumPy arrays and on CasADi SX (a Function of the same arrays, as the light verdict's
compiled figures use them) gives the same numbers bit for bit, and both give the values
worked out by hand here (the oracle: arithmetic in the test, not dmoc's)."""

import casadi as ca
import numpy as np
import pytest

from dmoc.results import figure_rules as rules
from dmoc.results.figure_rules import NUMPY, SYMBOLIC


def symbolic(rule, *arrays, **keywords):
    """`rule(SYMBOLIC, ...)` on SX symbols of the shapes of `arrays`, evaluated at them: a
    tuple of floats, or an array for a matrix result."""
    symbols = [ca.SX.sym(f"a{i}", *np.atleast_2d(a).shape) for i, a in enumerate(arrays)]
    out = rule(SYMBOLIC, *symbols, **keywords)
    outs = out if isinstance(out, tuple) else (out,)
    values = ca.Function("f", symbols, [ca.SX(x) for x in outs])(*[np.atleast_2d(a) for a in arrays])
    values = values if isinstance(values, (list, tuple)) else [values]
    if isinstance(out, tuple):
        return tuple(float(v) for v in values)
    return np.array(values[0])


def test_the_largest_relative_path_value_by_hand_and_in_both_evaluations():
    """g at 3 points, 2 rows: each row against max(1, max |g|) over all points (2 and 2),
    relative values 0.25, 0.5, 1 and -0.125, -1, 0.25: the largest, 1, at point 2, row 0;
    from point 1 on the same (the 2nd point from there); a row below zero gives none."""
    g = np.array([[0.5, -0.25], [1.0, -2.0], [2.0, 0.5]])
    assert rules.violation(NUMPY, g) == (1.0, 2, 0)
    assert symbolic(rules.violation, g) == (1.0, 2.0, 0.0)
    assert rules.violation(NUMPY, g, 1) == (1.0, 1, 0)
    assert symbolic(rules.violation, g, first=1) == (1.0, 1.0, 0.0)
    assert rules.violation(NUMPY, g / 4) == (0.5, 2, 0)               # unit 1 where max |g| < 1
    held = -np.abs(g)
    assert rules.violation(NUMPY, held) == (0.0, -1, -1) == tuple(symbolic(rules.violation, held))


def test_velocity_changes_by_hand_and_in_both_evaluations():
    """Two coordinates over 3 steps: x's end velocities 1, 2 | 2, 4 | 3, 3 (peak 4): changes
    |2 - 2| / 4 = 0 and |3 - 4| / 4 = 1/4; y barely moves (peak 1e-12 of x's): 0. The
    largest, 1/4, at the second interior knot; a resting x (span below its threshold) 0."""
    start = np.array([[1.0, 1e-12], [2.0, 0.0], [3.0, 1e-12]])
    end = np.array([[2.0, 0.0], [4.0, 1e-12], [3.0, 0.0]])
    expected = np.array([[0.0, 0.0], [0.25, 0.0]])
    changes = rules.relative_changes(NUMPY, start, end)
    assert np.array_equal(changes, expected)
    assert np.array_equal(symbolic(rules.relative_changes, start, end), expected)
    assert rules.largest_entry(NUMPY, changes) == (0.25, 1, 0)
    assert symbolic(rules.largest_entry, changes) == (0.25, 1.0, 0.0)
    q = np.array([[0.0, 0.0], [1e-9, 1.0], [0.0, 2.0], [0.0, 3.0]])     # x's span 1e-9
    rest = np.array([1e-6, 1e-6])
    assert not rules.still(NUMPY, changes, q, rest).any()
    assert not symbolic(rules.still, changes, q, rest[None, :]).any()


@pytest.mark.parametrize("seed", [0, 1])
def test_departures_and_scales_agree_bit_for_bit(seed):
    """Random knots and a replay off them by round-off, a coordinate that does not move and
    ties in the largest entry: the departures, the q scale and the first step beyond a
    tolerance are the same numbers in both evaluations, and the scale is the span by hand."""
    rng = np.random.default_rng(seed)
    q = np.column_stack([rng.normal(size=6), np.full(6, 2.0), rng.normal(size=6)])
    reached = q[1:] + rng.normal(scale=1e-8, size=(5, 3))
    unit = rules.q_scale(NUMPY, q)
    assert unit == max(np.max(q[:, i]) - np.min(q[:, i]) for i in range(3))
    assert symbolic(lambda ops, q: (rules.q_scale(ops, q),), q) == (unit,)
    each = rules.departures(NUMPY, reached, q[1:], unit)
    assert np.array_equal(each, np.abs(reached - q[1:]).max(axis=1) / unit)
    assert np.array_equal(symbolic(rules.departures, reached, q[1:], np.array([[unit]])).ravel(), each)
    tolerance = np.sort(each)[2]        # the third smallest: some steps beyond it
    first = int(np.flatnonzero(each > tolerance)[0])
    assert rules.first_beyond(NUMPY, each, tolerance) == first
    assert symbolic(lambda ops, e: (rules.first_beyond(ops, e, tolerance),), each[:, None]) == (first,)
    tied = np.array([[1.0, 3.0], [3.0, 0.0]])
    assert rules.largest_entry(NUMPY, tied) == (3.0, 0, 1) == tuple(symbolic(rules.largest_entry, tied))
    assert rules.scale(NUMPY, 0.0, 1e-13) == 1.0 and rules.scale(NUMPY, 1e-13, 5.0) == 5.0
