"""NumPy vectors to CasADi DM and back through lists: the same numbers, bit for bit, in
less time than CasADi's own conversions of NumPy arrays (benchmarks/peers.py resolve).
No call of dmoc goes through DM any more (the result's momenta, the last, go through
their Function's buffer since issue 41, like the IPOPT call and the data's tolerances:
`dmoc._util.numeric.Evaluator`); tests/optimize/test_resolve_overhead.py calls a DM
Function through `column` as its oracle.
"""

import casadi as ca
import numpy as np

from ..errors import InputError


def column(vector, rows=None):
    """The DM of a 1-d float array, through a list of floats: a column, or with `rows`
    the matrix of that many rows filled column by column (Fortran order)."""
    dm = ca.DM(vector.tolist())
    return dm if rows is None else ca.reshape(dm, rows, dm.numel() // rows)


def vector(dense):
    """The 1-d float array of a dense DM's entries, column by column (``dense.full()``
    raveled in Fortran order).

    Examples
    --------
    >>> vector(column(np.array([1.0, -0.0, 2.5]), rows=1)).tolist()
    [1.0, -0.0, 2.5]
    """
    if dense.nnz() != dense.numel():
        raise InputError(f"`dense` must be a dense DM; got {dense.nnz()} nonzeros of "
                         f"{dense.numel()} entries.")
    return np.array(dense.nonzeros())
