"""The KKT matrix of the transcribed NLP and its factorization: `dmoc.drivers.kkt_sensitivity`
solves it at an optimum for sensitivities, `dmoc.optimal_control.solver.newton_kkt` at the
iterates of a warm re-solve. The blocks are the exact
derivatives the solver uses (`SeparableNLP.derivatives`, expanded to SX), in the scaled NLP
IPOPT solves; per NLP `structure` their evaluation, the matrix's sparsity, the choice of
factorization and the solution are built once, and each call passes float arrays through
the Functions' buffers.
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..._util.cache import BoundedCache
from ..._util.numeric import Evaluator
from .evaluation import nlp_functions

_SYSTEMS = BoundedCache(16, "kkt_systems")          # by NLP structure
_LAYOUTS = BoundedCache(16, "kkt_layouts")          # by (NLP structure, fixed entries)
_SOLUTIONS = BoundedCache(16, "kkt_solutions")      # by (NLP structure, fixed and bounded entries, ..., method)

# -DEPENDENT_ROWS on the diagonal of the active rows' multiplier block: active rows that
# are dependent (a path row held at a knot and at the two stage points beside it, whose
# velocity is their mean) leave the multipliers non-unique and the KKT matrix singular;
# the shift picks one of them and moves dx by about DEPENDENT_ROWS |dlam|.
DEPENDENT_ROWS = 1e-12
# The symmetric matrix factored by LDL^T without pivoting is shifted by +REGULARIZATION on
# the rows of x and -REGULARIZATION on those of g (quasi-definite where the Hessian is
# positive: no pivot near zero, Vanderbei 1995), and its solution refined against the exact
# matrix, REFINEMENTS solves in all; accepted when the normwise backward error of each
# column and of a probe's (a generic right side, whose refinement stalls on a singular
# matrix) is at most BACKWARD_ERROR, else the exact matrix's sparse QR.
REGULARIZATION = 1e-6
REFINEMENTS = 3
BACKWARD_ERROR = 1e-13
# a nonzero of the QR's factors costs about QR_COST times one of the LDL^T's matrix or factor
# per solve (CasADi 3.8's "qr" and "ldl" on the knife edge and the rolling disk, N = 1000)
QR_COST = 2.0


@dataclass(frozen=True)
class KKTSystem:
    """The KKT matrix of `dmoc.drivers.kkt_sensitivity.solve_kkt` of one NLP structure, as the
    gather of its entries.

    Attributes
    ----------
    blocks : Evaluator
        ``(x (n_x,), p (n_p,), lam_g (n_g,)) -> (g (n_g, 1), grad_f (n_x, 1), values
        (1 + nnz_H + nnz_J, 1))``: the rows, the gradient of f and the values the matrix
        is gathered from, 0 then the nonzeros of the upper triangle of the Lagrangian's
        Hessian and of the Jacobian of g (`SeparableNLP.derivatives`, expanded).
    entries : tuple of ndarray of int
        (row, column, source, diagonal) of the entries of the (n_x + n_g) square matrix:
        the Hessian, J^T, J and the diagonal, one pattern whatever the active set. Entry i
        is values[source[i]] times the mask of its row plus the diagonal term diagonal[i]
        (0: none; else 1 + the index of the diagonal entry); an entry may be listed twice
        (a Hessian diagonal entry and the diagonal term), its terms summed.
    """

    blocks: Evaluator
    entries: tuple


def kkt_system(transcription):
    """The `KKTSystem` of the scaled NLP of `transcription`, built once per `structure`."""
    return _SYSTEMS.get(transcription.structure, lambda: _system(transcription.separable))


def _system(nlp):
    """The `KKTSystem` of the SeparableNLP `nlp`: its entries' sources by numpy, once."""
    functions = nlp_functions(nlp, expand=True)
    n_x, n_g, n = nlp.n_x, nlp.n_g, nlp.n_x + nlp.n_g
    hess_rows, hess_cols = (np.array(i) for i in functions["nlp_hess_l"].sparsity_out(0).get_triplet())
    jac_rows, jac_cols = (np.array(i) for i in functions["nlp_jac_g"].sparsity_out(1).get_triplet())
    in_hess, in_jac = 1 + np.arange(hess_rows.size), 1 + hess_rows.size + np.arange(jac_rows.size)
    strict = hess_rows != hess_cols
    # the triangle, its mirror, J^T, J, the diagonal
    rows = np.concatenate([hess_rows, hess_cols[strict], jac_cols, n_x + jac_rows, np.arange(n)])
    cols = np.concatenate([hess_cols, hess_rows[strict], n_x + jac_rows, jac_cols, np.arange(n)])
    source = np.concatenate([in_hess, in_hess[strict], in_jac, in_jac, np.zeros(n, int)])
    diagonal = np.concatenate([np.zeros(rows.size - n, int), 1 + np.arange(n)])
    x, p, lam = nlp.x, nlp.p, ca.MX.sym("lam_g", n_g)
    grad = functions["nlp_grad_f"](x, p)[1]
    g, jac = functions["nlp_jac_g"](x, p)
    hess = functions["nlp_hess_l"](x, p, 1, lam)
    values = ca.vertcat(0, *(ca.sparsity_cast(m, ca.Sparsity.dense(m.nnz(), 1)) for m in (hess, jac)))
    blocks = ca.Function("kkt_blocks", [x, p, lam], [g, grad, values], ["x", "p", "lam_g"],
                         ["g", "grad_f", "values"])
    return KKTSystem(Evaluator(blocks), (rows, cols, source, diagonal))


def _gathered(rows, cols, source, diagonal, shape):
    """(sparsity, source, row, diagonal) per nonzero of the matrix of `shape` whose entries
    are listed (`KKTSystem.entries`, renumbered): duplicates merged, column-major."""
    keys, slot = np.unique(cols * shape[0] + rows, return_inverse=True)
    merged = [np.zeros(keys.size, int), np.zeros(keys.size, int)]
    for into, values in zip(merged, (source, diagonal)):        # one of each per entry at most
        np.add.at(into, slot, values)
    sparsity = ca.Sparsity(*shape, np.searchsorted(keys // shape[0], np.arange(shape[1] + 1)).tolist(),
                           (keys % shape[0]).tolist())
    return sparsity, merged[0], keys % shape[0], merged[1]


def kkt_layout(transcription, fixed):
    """(kept, position, K, F, method) of the matrix of
    `dmoc.drivers.kkt_sensitivity.solve_kkt` without the entries `fixed` (int array): the
    mask (n_x + n_g,) of the rows and columns kept, their positions (the fixed ones
    numbered n_x + n_g + i), the `_gathered` matrix of the kept ones and of the fixed
    columns in the kept rows, and the cheaper method by the nonzeros each handles:
    "ldl", REFINEMENTS solves each through the matrix twice (the solve, the residual) and
    its factor once, or "qr", its factors V and R, weighted by QR_COST. Built once per NLP
    `structure` and `fixed`."""
    def build():
        n, (rows, cols, source, diagonal) = transcription.separable.n_x + transcription.separable.n_g, \
            kkt_system(transcription).entries
        kept = np.ones(n, bool)
        kept[fixed] = False
        m, position = int(kept.sum()), np.where(kept, np.cumsum(kept) - 1, -1)
        position[fixed] = n + np.arange(fixed.size)       # beyond the kept ones: columns moved to the right side
        square, side = kept[rows] & kept[cols], kept[rows] & ~kept[cols]
        K = _gathered(position[rows[square]], position[cols[square]], source[square], diagonal[square], (m, m))
        F = _gathered(position[rows[side]], position[cols[side]] - n, source[side], diagonal[side], (m, fixed.size))
        v, r, _, _ = K[0].qr_sparse(True)
        factor, _ = K[0].ldl(True)
        ldl = REFINEMENTS * (2 * K[0].nnz() + factor.nnz()) < QR_COST * (v.nnz() + r.nnz())
        return kept, position, K, F, "ldl" if ldl else "qr"
    return _LAYOUTS.get((transcription.structure, fixed.tobytes()), build)


def kkt_solution(transcription, k, fixed, bounded, equalities, method):
    """The Evaluator of ``(values, active_x, active_g, d_bound, r) -> dx`` (method "qr") or
    ``-> (dx, error)`` ("ldl"): the system of `dmoc.drivers.kkt_sensitivity.solve_kkt` for k
    parameters without the entries `fixed` (lbx == ubx, int array), whose dx is their
    bound's change; its matrix gathered from the `KKTSystem`'s values. "ldl": the entries
    held at a bound moved to the right side too, the matrix symmetric, shifted by
    +-REGULARIZATION, factored by CasADi's sparse LDL^T ("ldl", no pivoting; AMD ordering)
    and its solution refined against the exact matrix, REFINEMENTS solves, for the k
    columns and the probe (`_probe`); "qr": the exact matrix by its sparse QR (CasADi's
    "qr", which fails on a diagonal entry of R below 1e-12). Built once per NLP `structure`, `fixed`, `bounded` (the entries of x with a finite
    bound that are not fixed, int array), `equalities` (whether every row of g is an
    equality and `bounded` empty: every row of g held, no entry of x, whatever the
    multipliers), k and `method`.

    Inputs: `values` of `KKTSystem.blocks`; the 0/1 masks active_x (n_x,) and active_g
    (n_g,) of the entries and rows held at a bound; the change of the bound of each entry
    of x (n_x, k) and minus the change of (grad L, g) in p, (n_x + n_g, k), per unit of
    each parameter (`kkt_directions`). Outputs: dx/dtheta, (n_x, k), and for "ldl" the
    probe's solution as a last column, (n_x, k + 1), and the largest normwise backward
    error of the columns, (1, 1).
    """
    def build():
        nlp, (rows, cols, source, diagonal) = transcription.separable, kkt_system(transcription).entries
        n_x, n_g, n = nlp.n_x, nlp.n_g, nlp.n_x + nlp.n_g
        kept, position, K, F, _ = kkt_layout(transcription, fixed)
        m = K[0].size1()
        values = ca.MX.sym("values", int(source.max(initial=0)) + 1)
        a_x, a_g = ca.MX.sym("active_x", n_x), ca.MX.sym("active_g", n_g)
        d_bound, r = ca.MX.sym("d_bound", n_x, k), ca.MX.sym("r", n, k)
        kept_rows = np.flatnonzero(kept).tolist()
        # with `equalities` the masks are constants (CasADi folds their products away)
        held_x, held_g = (ca.DM.zeros(n_x), ca.DM.ones(n_g)) if equalities else (a_x, a_g)
        masks = ca.vertcat(1 - held_x, held_g)[kept_rows]  # the stationarity rows of the free entries, the held rows
        diagonal_terms = ca.vertcat(0, held_x, 1 - (1 + DEPENDENT_ROWS) * held_g)
        entries = values[K[1].tolist()] * masks[K[2].tolist()]
        d_fixed = d_bound[fixed.tolist(), :]
        moved = ca.mtimes(ca.MX(F[0], values[F[1].tolist()] * masks[F[2].tolist()]), d_fixed)
        held = ca.vertcat(ca.repmat(held_x, 1, k) * d_bound, ca.MX(n_g, k))[kept_rows, :]
        b = held + ca.repmat(masks, 1, k) * r[kept_rows, :] - moved
        if method == "qr":
            solution = ca.solve(ca.MX(K[0], entries + diagonal_terms[K[3].tolist()]), b, "qr")
            checks, columns = [], k
        else:
            # the held entries' columns to the right side: the matrix symmetric (rows and
            # columns masked), the held rows and entries identities
            inside = np.zeros(n, bool)
            inside[bounded] = True
            near = kept[rows] & inside[cols] & kept[cols]
            B = _gathered(position[rows[near]], np.searchsorted(bounded, cols[near]), source[near],
                          diagonal[near], (m, bounded.size))
            d_held = (held_x * d_bound)[bounded.tolist(), :] if bounded.size else ca.MX(0, k)
            probe = masks * ca.DM(_probe(n_x - fixed.size, m))
            right = ca.horzcat(b - ca.mtimes(ca.MX(B[0], values[B[1].tolist()] * masks[B[2].tolist()]), d_held),
                               probe)
            shift = ca.DM(np.concatenate([[0.0], np.full(n_x, REGULARIZATION), np.full(n_g, -REGULARIZATION)]))
            column_masks = masks[np.repeat(np.arange(m), np.diff(K[0].colind())).tolist()]
            matrix = ca.MX(K[0], entries * column_masks + diagonal_terms[K[3].tolist()] + shift[K[3].tolist()])
            regularization = ca.repmat(shift[(1 + np.flatnonzero(kept)).tolist()], 1, k + 1)
            solution, residual = ca.MX(m, k + 1), right
            for _ in range(REFINEMENTS):
                solution = solution + ca.solve(matrix, residual, "ldl")
                # the symmetric matrix's product as (z^T M)^T: a third less time in CasADi's mtimes
                residual = right - ca.mtimes(solution.T, matrix).T + regularization * solution
            scale = ca.fmax(1, ca.mmax(ca.fabs(values)))      # of the matrix: its entries, its identity rows
            errors = [ca.mmax(ca.fabs(residual[:, j]))
                      / (scale * ca.mmax(ca.fabs(solution[:, j])) + ca.mmax(ca.fabs(right[:, j])))
                      for j in range(k + 1)]
            checks, columns = [ca.mmax(ca.vertcat(*errors))], k + 1
        dx = ca.vertcat(solution, ca.horzcat(d_fixed, ca.MX.zeros(fixed.size, columns - k)))
        dx = dx[np.where(kept, position, position - n + m)[:n_x].tolist(), :]
        return Evaluator(ca.Function("kkt_solution", [values, a_x, a_g, d_bound, r], [dx, *checks],
                                     ["values", "active_x", "active_g", "d_bound", "r"],
                                     ["dx", "error"][:1 + len(checks)]))
    return _SOLUTIONS.get((transcription.structure, fixed.tobytes(), bounded.tobytes(), equalities, k, method),
                          build)


def _probe(free, m):
    """The probe's right side, shape (m,): entries of modulus in [1, 2] and random signs in
    the `free` stationarity rows (generic: a singular matrix leaves it inconsistent), zero
    in the rows of g (dependent active rows leave it consistent), fixed by a seed."""
    rng = np.random.default_rng(0)
    return np.concatenate([rng.uniform(1.0, 2.0, free) * rng.choice([-1.0, 1.0], free), np.zeros(m - free)])
