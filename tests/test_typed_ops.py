"""dmoc._util.typed_ops makes the nodes CasADi's operators make: a Function built from
either serializes to the same bytes (the oracle is CasADi's own operator), for SX and MX,
with a float on either side, and the operators' own results where the arguments are not
both symbolic of one kind."""

import casadi as ca
import numpy as np
import pytest

from dmoc._util import typed_ops

OPERATORS = [(typed_ops.plus, lambda a, b: a + b), (typed_ops.minus, lambda a, b: a - b),
             (typed_ops.times, lambda a, b: a * b), (typed_ops.divide, lambda a, b: a / b),
             (typed_ops.less, lambda a, b: a < b), (typed_ops.equal, lambda a, b: a == b),
             (typed_ops.less_equal, lambda a, b: a <= b)]


def _same(inputs, typed, reference):
    return (ca.Function("f", inputs, [typed]).serialize()
            == ca.Function("f", inputs, [reference]).serialize())


@pytest.mark.parametrize("kind", [ca.SX, ca.MX])
@pytest.mark.parametrize("typed, operator", OPERATORS)
def test_binary_operations_make_the_operators_nodes(kind, typed, operator):
    x, y, s = kind.sym("x", 3), kind.sym("y", 3), kind.sym("s")
    for a, b in [(x, y), (x, s), (s, y), (2.5, x), (x, 0.5)]:
        assert _same([x, y, s], typed(a, b), operator(a, b))


@pytest.mark.parametrize("kind", [ca.SX, ca.MX])
def test_unary_operations_total_and_column(kind):
    x, y = kind.sym("x", 3), kind.sym("y", 2, 2)
    assert _same([x], typed_ops.fabs(x), ca.fabs(x))
    assert _same([x], typed_ops.logic_not(x), ca.logic_not(x))
    assert _same([x], typed_ops.total([x, 2.0 * x, x * x]), sum([x, 2.0 * x, x * x]))
    assert _same([x, y], typed_ops.column(x), ca.vec(x))
    assert _same([x, y], typed_ops.column(y), ca.vec(y))


def test_other_arguments_take_the_operators():
    d = ca.DM([1.0, 2.0])
    assert np.array_equal(np.array(typed_ops.times(d, d)), np.array([[1.0], [4.0]]))
    assert typed_ops.plus(1, 2) == 3
    assert np.array_equal(np.array(typed_ops.fabs(np.array([-1.0, 2.0]))).ravel(), [1.0, 2.0])
    assert np.array_equal(np.array(typed_ops.column(np.eye(2))), np.array([[1.0], [0.0], [0.0], [1.0]]))


def test_sx_keeps_an_sx_and_converts_the_rest():
    x = ca.SX.sym("x", 3)
    assert typed_ops.sx(x) is x
    assert _same([x], typed_ops.sx(2.0 * x), ca.SX(2.0 * x))
    for value in (2.5, np.array([1.0, 2.0]), ca.DM([[1.0, 2.0]])):
        converted = typed_ops.sx(value)
        assert type(converted) is ca.SX
        np.testing.assert_array_equal(np.array(ca.DM(converted)), np.array(ca.DM(ca.SX(value))))
