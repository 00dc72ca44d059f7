"""Numeric evaluation of a CasADi Function on float arrays through its buffer interface
(`casadi.Function.buffer`): the arrays are read and written in place, with none of the
conversions to and from ``casadi.DM`` of an ordinary call, a fraction of its time for the
small Functions of a system; the same evaluation, so the same bits.
"""

import threading

import numpy as np

from ..errors import InputError
from .cache import BoundedCache


class Evaluator:
    """`function` evaluated on float arrays, its outputs as dense arrays.

    Parameters
    ----------
    function : casadi.Function
        With dense inputs.

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x", 2)
    >>> Evaluator(ca.Function("f", [x], [ca.horzcat(x[0], 2 * x[1])]))([1.0, 3.0])
    [array([[1., 6.]])]
    """

    def __init__(self, function):
        sparse = [i for i in range(function.n_in()) if not function.sparsity_in(i).is_dense()]
        if sparse:
            raise InputError(f"`function` {function.name()!r} must have dense inputs; "
                             f"input {sparse[0]} is sparse.")
        self.function = function
        self._inputs = [function.nnz_in(i) for i in range(function.n_in())]
        self._outputs = [_scatter(function.sparsity_out(i)) for i in range(function.n_out())]
        self._local = threading.local()         # a buffer per thread: calls may overlap
        self._vector = (function.n_in() == 1 and function.n_out() == 1     # `vector` applies
                        and function.sparsity_out(0).is_dense())

    def __reduce__(self):
        """Pickled as its Function (a closure that keeps an Evaluator, such as a problem's
        momenta, ships to a worker): the buffers are made anew on their first call."""
        return Evaluator, (self.function,)

    def __call__(self, *args):
        """The outputs at `args`, one per input, each the input's entries in column-major
        order (a vector of shape (n,) for an input (n, 1)), real and checked by the
        caller: a list of arrays of the outputs' shapes (rows, columns), structural
        zeros as 0.0."""
        buffer, run = self._buffer()
        inputs = [np.ascontiguousarray(a, dtype=float).ravel(order="F") for a in args]
        for i, (a, size) in enumerate(zip(inputs, self._inputs)):
            if a.size != size:
                raise InputError(f"`args[{i}]` must have {size} entries for "
                                 f"{self.function.name()!r}; got {a.size}.")
            buffer.set_arg(i, memoryview(a))          # `inputs` keeps them alive in run()
        nonzeros = [np.empty(len(rows)) for _, rows, _ in self._outputs]
        for i, values in enumerate(nonzeros):
            buffer.set_res(i, memoryview(values))
        _run(buffer, run)
        return [_dense(values, *output) for values, output in zip(nonzeros, self._outputs)]

    def vector(self, z):
        """The output's entries, a new 1-d array, of a Function of one input and one dense
        output at `z`, a C-contiguous 1-d float array of the input's entries: the call without
        the conversions of `__call__` (NumPy's calls on short arrays are a measurable part
        of a warm re-solve, benchmarks/peers.py resolve)."""
        if not (self._vector and type(z) is np.ndarray and z.dtype == np.float64 and z.ndim == 1
                and z.size == self._inputs[0] and z.flags.c_contiguous):
            raise InputError(f"`vector` evaluates {self.function.name()!r} on a C-contiguous "
                             f"1-d float array of {self._inputs[0]} entries when it has one input "
                             f"and one dense output; got {np.shape(z)} of {np.asarray(z).dtype}.")
        buffer, run = self._buffer()
        out = np.empty(len(self._outputs[0][1]))
        buffer.set_arg(0, memoryview(z))
        buffer.set_res(0, memoryview(out))
        _run(buffer, run)
        return out

    def stats(self):
        """The Function's statistics (``casadi.Function.stats``) of its last call, read
        through this thread's buffer (``function.stats()`` has none when only buffers
        have called the Function)."""
        return self._buffer()[0].stats()

    def _buffer(self):
        """(buffer, run) of this thread, made on its first call."""
        if not hasattr(self._local, "buffer"):
            self._local.buffer = self.function.buffer()
        return self._local.buffer


CHUNK = 4096      # steps per call of `per_step`'s mapped Function
_MAPPED = BoundedCache(32, "mapped_functions")      # (id of a Function, count) -> (it, its `mapped`)


def per_step(function, steps, *args):
    """The outputs of `function` (column-vector outputs) evaluated at each of `steps`
    steps: each of `args` an array whose first axis is the step (shape (steps, ...), its
    rows the input's entries) or a float given to every step; a list of arrays (steps, r).
    Long runs (steps >= CHUNK) go through one Function mapped over CHUNK steps, made once
    and called on buffers chunk by chunk (the same evaluation, the same bits; 12 times
    faster than mapping over all steps at 2e5 steps, which also builds a Function that
    large), short ones through ``function.map(steps)``."""
    if steps < CHUNK:
        columns = [_rows(a, 0, steps).T if isinstance(a, np.ndarray) else a for a in args]
        return [np.array(out).T for out in _as_list(function.map(steps)(*columns))]
    chunked = mapped(function, CHUNK)
    rows = [chunked.function.size1_out(i) for i in range(function.n_out())]
    outs = [np.empty((steps, r)) for r in rows]
    for start in range(0, steps, CHUNK):
        end = min(start + CHUNK, steps)
        chunk = [_padded(a, start, end) for a in args]
        for out, value in zip(outs, chunked(*chunk)):
            out[start:end] = value.T[:end - start]
    return outs


def _as_list(value):
    return value if isinstance(value, (list, tuple)) else [value]


def _padded(arg, start, end):
    """Rows `start:end` of `arg` as CHUNK columns (the last row repeated), or the float
    `arg` for every column."""
    if not isinstance(arg, np.ndarray):
        return np.full(CHUNK, float(arg))
    rows = _rows(arg, start, end)
    if end - start < CHUNK:
        rows = np.vstack([rows, np.repeat(rows[-1:], CHUNK - (end - start), axis=0)])
    return rows.T


def _rows(arg, start, end):
    """Rows `start:end` of `arg`, each flattened (explicit widths: 0 columns allowed)."""
    return arg[start:end].reshape(end - start, int(np.prod(arg.shape[1:])))


def mapped(function, count):
    """The Evaluator of `function` mapped over `count` columns (a serial map: each column the
    bits of a call of its own), made once per Function and count: keyed by the Function's
    id, the entry holding the Function so that the id stays its own while it lives."""
    return _MAPPED.get((id(function), count), lambda: (function, Evaluator(function.map(count))))[1]


def _run(buffer, run):
    """Evaluate a buffer's Function (`run`, the buffer's own call). A KeyboardInterrupt
    raised inside the Function (by CasADi's check of Python's signals in IPOPT's callbacks:
    IPOPT stops and returns its last iterate) is left set when the call returns, which
    Python reports as a SystemError caused by it; the outputs are written, and they are
    kept, the interrupt swallowed as CasADi's ordinary call swallows it
    (`dmoc.optimal_control.solver.interrupt`). An evaluation that fails (a nonzero return
    code: a linear solver's failed factorization) raises a RuntimeError, as CasADi's
    ordinary call does; its outputs are not written."""
    try:
        run()
    except SystemError as err:
        if not isinstance(err.__cause__, KeyboardInterrupt):
            raise
        return
    if buffer.ret() != 0:
        raise RuntimeError("Evaluation failed (its Function returned a nonzero code).")


def _scatter(sparsity):
    """(shape, rows, columns) of the nonzeros of `sparsity`; rows None when it is dense."""
    shape = (sparsity.size1(), sparsity.size2())
    if sparsity.is_dense():
        return shape, range(sparsity.nnz()), None
    return shape, *(np.array(index, dtype=int) for index in sparsity.get_triplet())


def _dense(values, shape, rows, columns):
    """The array of `shape` whose entries (`rows`, `columns`) are `values`, the others 0."""
    if columns is None:
        return values.reshape(shape, order="F")
    dense = np.zeros(shape)
    dense[rows, columns] = values
    return dense
