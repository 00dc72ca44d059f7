"""The simulator's cofactor inverse block by block (`dmoc.simulation.schur_complement.
block_inverse`), against NumPy's LU inverse of the same numbers (the oracle), on patterns
whose coupled rows are and are not adjacent, with a dense matrix (one block) as the case
that falls back to ``inv_minor``."""

import casadi as ca
import numpy as np
import pytest

from dmoc.simulation.schur_complement import block_inverse

PATTERNS = {
    # a rolling ball's block of the increments: the rotation's 3 x 3, then x's diagonal
    "3x3 + diagonal": [(i, j) for i in range(3) for j in range(3)] + [(3, 3), (4, 4)],
    # blocks {0, 2} and {1, 3}, interleaved
    "interleaved 2x2": [(0, 0), (0, 2), (2, 0), (2, 2), (1, 1), (1, 3), (3, 1), (3, 3)],
    # one block coupled through a single off-diagonal entry (not symmetric)
    "coupled": [(0, 0), (1, 1), (2, 2), (0, 2)],
    "dense 3x3": [(i, j) for i in range(3) for j in range(3)],
}


def _matrix(pattern):
    rows, cols = zip(*pattern)
    n = max(rows + cols) + 1
    sparsity = ca.Sparsity.triplet(n, n, list(rows), list(cols))
    return ca.SX.sym("a", sparsity), sparsity


@pytest.mark.parametrize("name", PATTERNS)
def test_inverse_is_numpys(name):
    A, sparsity = _matrix(PATTERNS[name])
    inverse = ca.Function("inverse", [A], [block_inverse(A)])
    rng = np.random.default_rng(3)
    values = rng.normal(size=sparsity.nnz()) + 3.0 * np.array(       # well away from singular
        [r == c for r, c in zip(*sparsity.get_triplet())])
    dense = np.array(ca.DM(sparsity, values))
    got = np.array(inverse(ca.DM(sparsity, values)))
    np.testing.assert_allclose(got, np.linalg.inv(dense), rtol=0, atol=1e-14 * np.abs(np.linalg.inv(dense)).max())


def test_blocks_take_fewer_operations_and_a_diagonal_entry_is_its_reciprocal():
    A, sparsity = _matrix(PATTERNS["3x3 + diagonal"])
    blocks, whole = (ca.Function("f", [A], [f(A)]) for f in (block_inverse, ca.inv_minor))
    assert blocks.n_instructions() < whole.n_instructions()
    values = np.linspace(1.0, 2.0, sparsity.nnz()) + 5.0 * np.array(
        [r == c for r, c in zip(*sparsity.get_triplet())])
    got = np.array(blocks(ca.DM(sparsity, values)))
    d = np.array(ca.DM(sparsity, values))[4, 4]
    assert got[4, 4] == 1.0 / d and got[4, :4].tolist() == [0.0] * 4
