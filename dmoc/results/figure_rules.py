"""The verdict's figures stated once (results stage, issue 41): the replay's relative
departures, the relative velocity changes at the knots and the largest of them, the
velocity bounds as knot rows and the largest relative path value, each written against a
small set of array operations `ops` that two evaluations provide: `NUMPY` on arrays (the
full verdict, `dmoc.drivers.verdict.judge`, the light verdict's NumPy path and the verdict
on SO(3)) and `SYMBOLIC` on CasADi SX matrices (the light verdict's compiled Function,
`dmoc.drivers.verdict_figures`). Both apply the same operations to the same numbers (max,
min, abs, differences and quotients, which round alike), so their figures agree bit for
bit (docs/verification.md, "The light verdict of a re-solve").

Arrays are time-major, as everywhere: a row per knot, step or point, a column per
coordinate or row of the constraints.
"""

import casadi as ca
import numpy as np

# Below this size an optimum's q or p gives no scale (it does not move from the origin).
NO_SCALE = 1e-12
# A coordinate is at rest, for its velocity changes, where its peak is below this part of
# the largest coordinate's.
AT_REST = 1e-9


class _NumPy:
    """The operations on NumPy arrays (and floats)."""

    @staticmethod
    def where(condition, a, b):
        """np.where, or for a scalar `condition` the chosen value itself."""
        if np.ndim(condition) == 0:
            return a if condition else b
        return np.where(condition, a, b)

    @staticmethod
    def maximum(a, b):
        return np.maximum(a, b)

    @staticmethod
    def down(row, like):
        """The row (1, n) or (n,) `row` against `like` (rows, n): NumPy broadcasts it."""
        return row

    @staticmethod
    def chosen(condition, values, fallbacks):
        """`values` (a tuple) where the scalar `condition` holds, else `fallbacks`."""
        return values if condition else fallbacks

    @staticmethod
    def largest(x):
        return x.max()

    @staticmethod
    def row_largest(x):
        """The largest entry of each row of `x`, shape (rows,)."""
        return x.max(axis=1)

    @staticmethod
    def column_largest(x):
        return x.max(axis=0)

    @staticmethod
    def column_smallest(x):
        return x.min(axis=0)

    @staticmethod
    def columns(parts, like):
        """The columns `parts` side by side; none: (rows of `like`, 0)."""
        return np.column_stack(parts) if parts else np.zeros((like.shape[0], 0))

    @staticmethod
    def first(flags):
        """The index of the first true entry of the 1-d `flags`, -1 if none."""
        found = np.flatnonzero(flags)
        return int(found[0]) if found.size else -1

    @staticmethod
    def position(x):
        """(the first largest entry of `x`, its row, its column), rows read one after
        another (NumPy's argmax: the first NaN where there is one)."""
        row, column = np.unravel_index(np.argmax(x), x.shape)
        return float(x[row, column]), int(row), int(column)


class _Symbolic:
    """The same operations on CasADi SX matrices (`columns` and the arithmetic on MX too),
    unrolled entry by entry where NumPy reduces along an axis; a row (1, n) is repeated
    down the rows where NumPy broadcasts it."""

    @staticmethod
    def where(condition, a, b):
        rows = max(x.shape[0] for x in (condition, a, b) if isinstance(x, ca.SX))
        wide = [ca.repmat(x, rows, 1) if isinstance(x, ca.SX) and x.shape[0] == 1 and rows > 1 else x
                for x in (condition, a, b)]
        return ca.if_else(*wide)

    @staticmethod
    def maximum(a, b):
        return ca.fmax(a, b)

    @staticmethod
    def down(row, like):
        return ca.repmat(row, like.shape[0], 1)

    @staticmethod
    def chosen(condition, values, fallbacks):
        return tuple(ca.if_else(condition, x, y) for x, y in zip(values, fallbacks))

    @staticmethod
    def largest(x):
        return ca.mmax(ca.densify(x))

    @staticmethod
    def row_largest(x):
        return ca.vertcat(*[_Symbolic.largest(x[k, :]) for k in range(x.shape[0])])

    @staticmethod
    def column_largest(x):
        return ca.horzcat(*[_Symbolic.largest(x[:, i]) for i in range(x.shape[1])])

    @staticmethod
    def column_smallest(x):
        return ca.horzcat(*[ca.mmin(ca.densify(x[:, i])) for i in range(x.shape[1])])

    @staticmethod
    def columns(parts, like):
        return ca.horzcat(*parts) if parts else type(like)(like.shape[0], 0)

    @staticmethod
    def first(flags):
        index = -1
        for j in reversed(range(flags.numel())):
            index = ca.if_else(flags[j], j, index)
        return index

    @staticmethod
    def position(x):
        values = ca.vec(x.T)            # rows one after another
        top = _Symbolic.largest(values)
        index = _Symbolic.first(values == top)
        row = ca.floor(index / x.shape[1])
        return top, row, index - row * x.shape[1]


NUMPY, SYMBOLIC = _NumPy(), _Symbolic()


def scale(ops, *sizes):
    """The first of `sizes` above NO_SCALE, as the unit of a relative departure; 1 (the
    system's units) where none is: the data give no scale."""
    unit = 1.0
    for size in reversed(sizes):
        unit = ops.where(size > NO_SCALE, size, unit)
    return unit


def spans(ops, q):
    """max_k q_k,i - min_k q_k,i of each coordinate of the knots `q` (N + 1, n), (n,)."""
    return ops.column_largest(q) - ops.column_smallest(q)


def q_scale(ops, q):
    """The unit of a departure in q: the span of the configurations `q` (N + 1, n) (the
    largest of `spans`), or their size where they do not move."""
    return scale(ops, ops.largest(spans(ops, q)), ops.largest(abs(q)))


def departures(ops, reached, knots, unit):
    """max_i |reached_k,i - knots_k,i| / unit of each row k, shape (rows,): how far a
    replay's states `reached` are from the optimum's `knots` (both (rows, n))."""
    return ops.row_largest(abs(reached - knots)) / unit


def first_beyond(ops, each, tolerance):
    """The index of the first entry of `each` above `tolerance`, -1 if none."""
    return ops.first(each > tolerance)


def relative_changes(ops, start, end):
    """|start_k - end_{k-1}| / peak per coordinate at the interior knots k = 1 ... N - 1,
    shape (N - 1, n), of the velocities `start` and `end` (N, n) of each step's
    interpolant at its two ends; the peak max |start|, |end| of each coordinate; 0 for a
    coordinate at rest (peak at most AT_REST of the largest coordinate's)."""
    if start.shape[0] < 2:
        return start[1:, :]
    peak = ops.maximum(ops.column_largest(abs(start)), ops.column_largest(abs(end)))
    moving = peak > AT_REST * ops.maximum(ops.largest(peak), 0.0)
    change = abs(start[1:, :] - end[:-1, :])
    return ops.where(moving, change / ops.down(ops.where(moving, peak, 1.0), change), 0.0)


def still(ops, changes, q, rest):
    """`changes` (N - 1, n) with 0 for each coordinate whose span over the knots `q` (N + 1,
    n) is at most its `rest` threshold (n,): a coordinate at rest within IPOPT's tolerance,
    whose velocity "jumps" are noise."""
    if changes.shape[0] == 0:
        return changes
    return ops.where(spans(ops, q) <= rest, 0.0, changes)


def largest_entry(ops, x):
    """(the largest entry of `x` (rows, columns), its row, its column), the first of equal
    ones reading row after row; (0, 0, 0) for an `x` without rows."""
    if x.shape[0] == 0:
        return 0.0, 0, 0
    return ops.position(x)


def bound_rows(ops, v, lower, upper):
    """The velocity bounds as rows g <= 0 at the knots, shape (N + 1, rows): lower_i -
    v_k,i, then v_k,i - upper_i, for the finite bounds, v (N + 1, n) the knot velocities;
    `lower`, `upper` pairs (the indices i of the finite bounds, their values)."""
    parts = [sign * (v[:, i] - bound[j]) for (index, bound), sign in ((lower, -1.0), (upper, 1.0))
             for j, i in enumerate(index)]
    return ops.columns(parts, v)


def violation(ops, g, first=0):
    """(the largest g relative to its row's scale max(1, max |g|) over every point of g
    (points, rows), its point from `first` on, its row) over the points from `first` on;
    (0, -1, -1) where no point has rows or none exceeds 0."""
    if g.shape[0] <= first or g.shape[1] == 0:
        return 0.0, -1, -1
    unit = ops.down(ops.maximum(ops.column_largest(abs(g)), 1.0), g[first:, :])
    top, point, row = largest_entry(ops, g[first:, :] / unit)
    return ops.chosen(top <= 0, (0.0, -1, -1), (top, point, row))
