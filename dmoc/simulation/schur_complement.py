"""The Newton update of one step of the simulator (`dmoc.simulation.stepper`): J^{-1} g of
the step equations, through the Schur complement of their multipliers (the constraint rows,
omega_d (28) or the stage rule's moments, do not involve them); by QR when the blocks are
large.
"""

import casadi as ca

MINOR_UNKNOWNS = 6  # blocks up to this size are inverted by cofactors: fewer operations than QR
DENSE_MINOR = 4     # a dense Jacobian without multipliers larger than this takes QR (`_inverse_times`)


def newton_update(g, y, unknowns, J=None):
    """J^{-1} g, J = dg/dy, in few operations: the equations are (left, stage) rows and
    constraint rows, the unknowns positions x = (dq, ds) and multipliers nu, and J =
    [H G; C 0] (omega_d does not involve nu), so nu follows from the m x m Schur
    complement C H^{-1} G, H^{-1} and its inverse by cofactors when they are small;
    QR otherwise, and also without multipliers when QR takes fewer operations than the
    cofactors (a dense block: `_inverse_times`). A singular H (a degenerate Lagrangian) gives a non-finite step, which
    the line-search Newton redoes.

    Parameters
    ----------
    g : casadi.SX, shape (unknowns.size, 1)
        The step equations: the "left" and "stage" rows, then the "constraint" rows
        (`dmoc.principle.explicit.SOLVED_ROWS`).
    y : casadi.SX, shape (unknowns.size, 1)
        The unknowns' symbols.
    unknowns : Layout
        The blocks of `y`: dq, nu and ds (`DiracStepper.unknowns`).
    J : casadi.SX, shape (unknowns.size, unknowns.size), optional
        dg/dy where the caller has it already (`dmoc.simulation.fast_path.step_rows`).

    Returns
    -------
    casadi.SX, shape (unknowns.size, 1)
    """
    J = ca.jacobian(g, y) if J is None else J
    x = [i for name in ("dq", "ds") for i in range(unknowns.slice(name).start,
                                                   unknowns.slice(name).stop)]
    nu, k = list(range(unknowns.slice("nu").start, unknowns.slice("nu").stop)), len(x)
    if k > MINOR_UNKNOWNS or len(nu) > MINOR_UNKNOWNS or J[k:, nu].nnz():
        return ca.solve(J, g)
    if not nu:
        return _inverse_times(J, g)
    H_inv = block_inverse(J[:k, x])
    G, C, r_x, r_nu = J[:k, nu], J[k:, x], g[:k], g[k:]
    d_nu = ca.mtimes(ca.inv_minor(ca.mtimes([C, H_inv, G])), ca.mtimes([C, H_inv, r_x]) - r_nu)
    delta = ca.SX.zeros(y.numel())
    delta[x] = ca.mtimes(H_inv, r_x - ca.mtimes(G, d_nu))
    delta[nu] = d_nu
    return delta


def _inverse_times(J, g):
    """J^{-1} g by cofactors or by QR, whichever takes fewer operations for the sparsity of
    J (counted after common-subexpression elimination, which only the cofactors gain from):
    cofactors for small or sparse J, QR for a dense one. A dense J of more than
    DENSE_MINOR unknowns goes to QR without counting (building its cofactors costs 0.1 s
    at 6 x 6): by cofactors a dense 5 x 5 takes 579 operations (2004 without the
    elimination, as in the virtual machine) and a 6 x 6 1545 (13769), by QR 370 and 603."""
    if J.nnz() == J.numel() and J.size1() > DENSE_MINOR:
        return ca.solve(J, g)
    A, r = ca.SX.sym("J", J.sparsity()), ca.SX.sym("g", g.sparsity())
    cofactors, qr = ca.mtimes(block_inverse(A), r), ca.solve(A, r)
    count = [ca.Function("x", [A, r], [x]).n_instructions() for x in (ca.cse(cofactors), qr)]
    return ca.mtimes(block_inverse(J), g) if count[0] <= count[1] else ca.solve(J, g)


def block_inverse(A):
    """A^{-1} of a small square SX matrix by cofactors, block by block: the rows and columns
    that A's sparsity couples (the connected parts of its pattern) form diagonal blocks
    of A, each inverted on its own, the rest of A^{-1} zero. The same inverse as
    ``inv_minor(A)`` in fewer operations, built in less time (a rigid body rolling on a
    plane: its 5 x 5 block of the increments is a 3 x 3 block of the rotation and 2 x 2
    diagonal, 0.13 + 0.04 ms against 0.56 ms), and without round-off across blocks (a
    diagonal entry's inverse is 1/a, not a ratio of products of the others)."""
    rows, cols = A.sparsity().get_triplet()
    part = list(range(A.size1()))

    def root(i):
        while part[i] != i:
            i = part[i]
        return i
    for i, j in zip(rows, cols):
        part[root(i)] = root(j)
    blocks = {}
    for i in range(A.size1()):
        blocks.setdefault(root(i), []).append(i)
    if len(blocks) == 1:
        return ca.inv_minor(A)
    inverse = ca.SX(A.size1(), A.size2())
    for block in blocks.values():
        inverse[block, block] = ca.inv_minor(A[block, block])
    return inverse
