"""Named blocks of flat vectors: the one helper behind the step residual's inputs and rows,
the simulator's carried state and the optimizer's decision and constraint vectors, so that
no module packs or unpacks by raw offsets.
"""

import casadi as ca
import numpy as np

from . import typed_ops


class Layout:
    """Named blocks of a flat vector: name -> (offset, rows, cols), column-major blocks.

    Parameters
    ----------
    blocks : sequence of (str, int or (int, int))
        Block names in order, each with its size (a column of that many rows) or its
        (rows, cols) shape.

    Examples
    --------
    >>> lay = Layout([("q", 2), ("lam", 1)])
    >>> lay.size, lay.slice("lam")
    (3, slice(2, 3, None))
    >>> lay.split(np.arange(3.0))["q"]
    array([0., 1.])
    """

    def __init__(self, blocks):
        self.blocks, offset = {}, 0
        for name, shape in blocks:
            rows, cols = (shape, 1) if np.ndim(shape) == 0 else shape
            self.blocks[name] = (offset, int(rows), int(cols))
            offset += int(rows) * int(cols)
        self.size = offset
        # made once: a simulation's results split its arrays with them run by run
        self._slices = {name: slice(offset, offset + rows * cols)
                        for name, (offset, rows, cols) in self.blocks.items()}

    def slice(self, name):
        """The slice of block `name` in the flat vector."""
        return self._slices[name]

    def slices(self):
        """{name: slice} of every block, in order."""
        return dict(self._slices)

    def numel(self, name):
        """Number of entries of block `name`."""
        _, rows, cols = self.blocks[name]
        return rows * cols

    def unpack(self, vector, name):
        """Block `name` of `vector` (CasADi or numpy) as a (rows, cols) matrix."""
        _, rows, cols = self.blocks[name]
        part = vector[self.slice(name)]
        if isinstance(part, np.ndarray):
            return part.reshape(cols, rows).T
        return ca.reshape(part, rows, cols)

    def split(self, vector):
        """{name: block} of a flat column `vector`: CasADi columns or numpy 1-d arrays
        (along the last axis for a stack of vectors, shape (k, size))."""
        if isinstance(vector, np.ndarray):
            return {name: vector[..., s] for name, s in self._slices.items()}
        offsets = [s.start for s in self.slices().values()] + [self.size]
        return dict(zip(self.blocks, ca.vertsplit(vector, offsets)))   # columns, also when empty

    def join(self, values):
        """The flat CasADi column of `values` {name: column}, blocks in order."""
        return ca.vertcat(*[typed_ops.column(values[name]) for name in self.blocks])

    def locate(self, index):
        """(block name, row, column) of a flat index."""
        for name, (offset, rows, cols) in self.blocks.items():
            if offset <= index < offset + rows * cols:
                return name, (index - offset) % rows, (index - offset) // rows
        raise IndexError(index)

    def __repr__(self):
        return "Layout(" + ", ".join(f"{k}: {r}x{c}" for k, (_, r, c) in self.blocks.items()) + ")"


def step_symbols(n, n_stages, n_controls):
    """CasADi column symbols of one step's blocks, by name: q0, p0, q1, p1 (n), s
    (n_stages), u (n_controls), h (1), the inputs of the step residual but lam."""
    sizes = {"q0": n, "p0": n, "q1": n, "p1": n, "s": n_stages, "u": n_controls, "h": 1}
    return {name: ca.SX.sym(name, size) for name, size in sizes.items()}
