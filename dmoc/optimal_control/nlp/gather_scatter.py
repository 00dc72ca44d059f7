"""Consumer 2's NLP, the index arithmetic of its separable assembly
(`dmoc.optimal_control.nlp.separable`): `window` gathers the entries of x, p or the multipliers that
the instances of a term read, by slices where the index array steps through blocks and by
one gather otherwise, and `assembled` scatters the terms' derivative nonzeros, placed by
global (row, column) indices, into one sparse matrix, summing shared entries: the gradient,
Jacobian and Hessian of the Lagrangian that IPOPT needs (docs/stages/optimize.md).
"""

import casadi as ca
import numpy as np

# One CasADi operation called from Python costs about what passing 300 indices to it does
# (benchmarks/dmoc_vs_collocation.py, its build split): the rate by which `window` chooses
# between slicing and one gather.
INDICES_PER_OPERATION = 300


def window(vector, index):
    """vector[index] as an (rows, M) matrix, `index` of shape (rows, M).

    Rows that step through a block of the vector (the window of a step's q, lam, u: a run
    of L consecutive entries advancing by L per instance) or that every instance shares
    can be sliced, in O(1) operations, instead of gathered by a list of all rows x M
    entries. Whichever costs fewer operations (`INDICES_PER_OPERATION`) is built: slices
    for the long windows of the step terms, one gather for the short ones.
    """
    rows, M = index.shape
    if rows == 0:
        return ca.MX(0, M)
    runs = _runs(index)
    gather_cost = (1 if M == 1 else 2) + index.size / INDICES_PER_OPERATION
    if runs is None or gather_cost <= 2 * len(runs) + (len(runs) > 1):
        flat = vector[index.ravel(order="F").tolist()]
        return flat if M == 1 else ca.reshape(flat, rows, M)
    parts = []
    for r, L, step in runs:
        first = int(index[r, 0])
        if step == L:
            parts.append(ca.reshape(vector[first:first + L * M], L, M))
        elif step == 0:
            parts.append(ca.repmat(vector[first:first + L], 1, M))
        else:
            parts.append(ca.reshape(vector[index[r:r + L].ravel(order="F").tolist()], L, M))
    return ca.vertcat(*parts)


def _runs(index):
    """The rows of `index` (rows, M) as runs (first row, length L, step): L rows of
    consecutive entries that all advance by `step` per instance; None if some row does not
    advance by a constant step."""
    rows, M = index.shape
    stride = index[:, -1] - index[:, 0] if M > 1 else np.zeros(rows, int)
    step = stride // (M - 1) if M > 1 else stride
    if M > 1 and not (index == index[:, :1] + step[:, None] * np.arange(M)).all():
        return None
    runs, r = [], 0
    while r < rows:
        L = 1
        while r + L < rows and index[r + L, 0] == index[r, 0] + L and step[r + L] == step[r]:
            L += 1
        runs.append((r, L, int(step[r])))
        r += L
    return runs


def gather(vector, order):
    """The entries of `vector` in the order of the int array `order`, by one gather."""
    return vector[order.tolist()]


def assembled(values, where, shape):
    """The sparse matrix of `shape` whose entry (i, j) sums the values placed there.

    values[t] is an (nnz_t, M_t) matrix; where[t] = (rows, cols), both (nnz_t, M_t) arrays
    of global indices for its entries. No values: the zero matrix.
    """
    if not values:
        return ca.MX(*shape)
    values = ca.vertcat(*[ca.vec(v) if v.size2() > 1 else v for v in values])
    rows = np.concatenate([r.ravel(order="F") for r, _ in where]).astype(np.int64)
    cols = np.concatenate([c.ravel(order="F") for _, c in where]).astype(np.int64)
    # the entries' column-major keys, sorted once by numpy's stable sort: that one order
    # gives the unique keys, each entry's slot, and the permutation of the values when no
    # entry is shared (np.unique with the inverse would need a second sort for it)
    entry_keys = cols * shape[0] + rows
    order = np.argsort(entry_keys, kind="stable")
    ordered = entry_keys[order]
    first = np.r_[True, ordered[1:] != ordered[:-1]] if ordered.size else np.zeros(0, bool)
    keys = ordered[first]
    colind = np.searchsorted(keys // shape[0], np.arange(shape[1] + 1))
    sparsity = ca.Sparsity(shape[0], shape[1], colind.tolist(), (keys % shape[0]).tolist())
    if keys.size == rows.size:          # no entry shared: a permutation of the values
        nonzeros = gather(values, order)
    else:
        slot = np.empty_like(order)
        slot[order] = np.cumsum(first) - 1
        n = rows.size
        summation = ca.DM(ca.Sparsity(keys.size, n, list(range(n + 1)), slot.tolist()), 1.0)
        nonzeros = ca.mtimes(ca.MX(summation), values)
    return ca.MX(sparsity, nonzeros)
