"""Warm re-solves by Newton's method on the KKT conditions (consumer 2, its solver half).

A re-solve from an optimum of the same NLP structure with new boundary data starts next to
the new optimum; when every row of g is an equality and no entry of x has a bound but the
fixed ones (lbx == ubx: the boundary data, moved onto their new values by the start), the
optimum is a root of the KKT conditions

    grad f(x) + J(x)^T lam = 0   (the free entries of x),    g(x) = 0,

and Newton's method on them, the matrix [[H, J^T], [J, 0]] of `kkt_matrix` (the exact
Hessian of the Lagrangian and Jacobian IPOPT uses), reaches it in as many iterations as
IPOPT takes from the same start, without IPOPT's overhead per iteration (its barrier
bookkeeping, MUMPS's analysis). The point is accepted only as IPOPT would accept it: the
stationarity of the free entries at most ``tol`` and every row at most
``constr_viol_tol`` (IPOPT's options, raised by `ipopt.data_tolerances` where the data
demand it), the error falling at every iteration, and the KKT matrix there of inertia
(n_free, n_g, 0) (counted from the signs of its LDL^T pivots), i.e. the Hessian positive
definite on the constraints' tangent space and the Jacobian of full rank: a strict local
minimum, not a saddle or a maximum (Nocedal & Wright, Numerical Optimization, 2nd ed.,
Thm. 12.6 and Sec. 16.2). Otherwise `newton_resolve` returns None and IPOPT solves from
the same start. A structure on which Newton's method was refused REFUSALS_BEFORE_IPOPT
times in a row is left to IPOPT from then on (until `dmoc.clear_caches`): on a car in SI
units (1500 kg, its scaled NLP's entries spanning 1e9) the iteration stalls above `tol`
and the LDL^T pivots of the shifted matrix do not give its inertia, and each attempt cost
0.7-1.1 ms before IPOPT's 7-9 ms re-solve.
"""

import time

import casadi as ca
import numpy as np

from ..._util.cache import BoundedCache
from ..._util.layout import Layout
from ..._util.numeric import Evaluator
from ..nlp.evaluation import nlp_functions
from ..nlp.kkt_matrix import DEPENDENT_ROWS, REGULARIZATION, kkt_layout, kkt_system
from .ipopt import packed_outputs

# Newton steps before a re-solve is handed to IPOPT: a start in the region of Newton's
# quadratic convergence needs 2-4 (the peer problems of benchmarks/peers.py resolve)
MAX_ITERATIONS = 6
# the IPOPT options a Newton re-solve takes (its tolerances) or that mean nothing to it;
# given any other, a re-solve is IPOPT's
NEWTON_OPTIONS = frozenset({"tol", "constr_viol_tol", "print_level"})
# refusals in a row on one structure after which its re-solves go to IPOPT at once
REFUSALS_BEFORE_IPOPT = 2
_STEPS = BoundedCache(16, "newton_steps")        # by (NLP structure, fixed entries)
_REFUSALS = BoundedCache(64, "newton_refusals")  # by NLP structure: [refusals in a row]
_PACKINGS = BoundedCache(16, "newton_packings")  # by NLP structure


def applies(transcription, lbx, ubx, lbg, ubg):
    """Whether `newton_resolve` may solve the scaled NLP of `transcription` with these
    bounds: every row an equality, every entry of x fixed or unbounded."""
    free = lbx != ubx
    return bool(np.all(lbg == ubg) and np.all(np.isinf(lbx[free])) and np.all(np.isinf(ubx[free])))


def newton_resolve(transcription, x0, lam_g0, bounds, fixed, tolerances):
    """The optimum of the scaled NLP of `transcription` from the warm start (x0, lam_g0)
    by Newton's method on its KKT conditions, or None when it is not reached as the module
    says.

    Parameters
    ----------
    transcription : Transcription
    x0 : ndarray, shape (n_x,)
        The start in the scaled NLP, its fixed entries on their bounds.
    lam_g0 : ndarray, shape (n_g,)
        The start's multipliers of g, scaled (lam_g / g_scale).
    bounds : tuple of ndarray
        (lbx, ubx, lbg, ubg), scaled, such that `applies`.
    fixed : ndarray of int
        The entries with lbx == ubx (`fixed_multipliers.fixed_entries`).
    tolerances : tuple of float
        (tol, constr_viol_tol) of the solve.

    Returns
    -------
    (dict, int, float) or None
        The outputs `ipopt.PackedSolver` gives (x, f, g, lam_x, lam_g, on_bound,
        largest, row, result_x, result_lam_x, result_lam_g, x_norm1; lam_x zero: the
        fixed entries' multipliers are completed as IPOPT's are), the Newton iterations and
        the seconds they took.
    """
    tic = time.perf_counter()
    T = transcription
    refusals = _REFUSALS.get(T.structure, lambda: [0])
    if refusals[0] >= REFUSALS_BEFORE_IPOPT:
        return None
    solved = _iterate(T, x0, lam_g0, fixed, tolerances)
    refusals[0] = 0 if solved is not None else refusals[0] + 1
    if solved is None:
        return None
    x, lam_g, iterations = solved
    lbx, ubx, lbg, ubg = bounds
    packing, layout = _PACKINGS.get(T.structure, lambda: _packing(T))
    sol = layout.split(packing.vector(np.concatenate([x, T.p, lam_g, lbx, ubx, lbg, ubg])))
    return sol, iterations, time.perf_counter() - tic


def _iterate(T, x0, lam_g0, fixed, tolerances):
    """(x, lam_g, iterations) of Newton's method on the KKT conditions from (x0, lam_g0)
    when it is accepted as the module says, else None."""
    step, signs = _STEPS.get((T.structure, fixed.tobytes()), lambda: _newton_step(T, fixed))
    n_x, n_g = x0.size, lam_g0.size
    z = np.concatenate([x0, T.p, lam_g0])
    previous = np.inf
    for iterations in range(MAX_ITERATIONS + 1):
        out = step.vector(z)
        error = max(out[-2] / tolerances[0], out[-1] / tolerances[1])
        if not error < previous:          # growing, stalled, or NaN: not converging
            return None
        if error <= 1.0:
            break
        previous = error
        z[:n_x], z[-n_g:] = out[:n_x], out[n_x:n_x + n_g]
    else:
        return None
    negative, positive = signs.vector(z)
    if negative != n_g or positive != n_x - fixed.size:
        return None
    return z[:n_x], z[-n_g:], iterations


def _newton_step(transcription, fixed):
    """(Evaluator of ``[x; p; lam_g] -> [x + dx; lam_g + dlam; stationarity; feasibility]``,
    Evaluator of ``[x; p; lam_g] -> [negative, positive pivots]``): the Newton step on the
    KKT conditions with the `fixed` entries held, and the errors at the point it starts
    from (the largest |grad_x L| over the free entries and |g|); the inertia of the KKT
    matrix by the signs of the pivots of its LDL^T (AMD ordering, no pivoting), both of the
    matrix shifted by +-REGULARIZATION on the rows of x and g (quasi-definite where the
    Hessian is positive), whose solution Newton's iteration refines."""
    nlp = transcription.separable
    n_x, n_g, n_p, n = nlp.n_x, nlp.n_g, nlp.n_p, nlp.n_x + nlp.n_g
    functions = nlp_functions(nlp, expand=True)
    jacobian, hessian = functions["nlp_jac_g"].sparsity_out(1), functions["nlp_hess_l"].sparsity_out(0)
    kept, position, K, _, _ = kkt_layout(transcription, fixed)
    m = K[0].size1()
    z = ca.MX.sym("z", n_x + n_p + n_g)
    x, p, lam = z[:n_x], z[n_x:n_x + n_p], z[n_x + n_p:]
    g, grad, values = kkt_system(transcription).blocks.function(x, p, lam)
    gradient = grad + ca.mtimes(ca.MX(jacobian, values[1 + hessian.nnz():]).T, lam)
    # the diagonal terms by their index in `KKTSystem.entries` (0: none): the dependent
    # rows' shift of the multipliers' block and the regularization
    terms = ca.DM(np.concatenate([[0.0], np.full(n_x, REGULARIZATION),
                                  np.full(n_g, -REGULARIZATION - DEPENDENT_ROWS)]))
    entries = values[K[1].tolist()] + terms[K[3].tolist()]
    d = ca.solve(ca.MX(K[0], entries), -ca.vertcat(gradient, g)[np.flatnonzero(kept).tolist()], "ldl")
    dz = ca.vertcat(d, ca.MX(fixed.size, 1))[np.where(kept, position, position - n + m).tolist()]
    free = np.flatnonzero(kept[:n_x]).tolist()
    errors = ca.vertcat(ca.mmax(ca.fabs(gradient[free])), ca.mmax(ca.fabs(g)))
    step = ca.Function("newton_kkt_step", [z], [ca.vertcat(x + dz[:n_x], lam + dz[n_x:], errors)])
    v = ca.SX.sym("v", K[0].nnz())
    pivots = ca.ldl(ca.SX(K[0], v), True)[0]
    signs = ca.Function("ldl_signs", [v], [ca.vertcat(ca.sum1(pivots < 0), ca.sum1(pivots > 0))])
    inertia = ca.Function("newton_kkt_inertia", [z], [signs(entries)])
    return Evaluator(step), Evaluator(inertia)


def _packing(transcription):
    """(Evaluator of ``[x; p; lam_g; lbx; ubx; lbg; ubg] -> the packed outputs``, their
    Layout): f and g at x and what `ipopt.packed_outputs` adds, as IPOPT's packed call
    gives them."""
    nlp = transcription.separable
    n_x, n_g = nlp.n_x, nlp.n_g
    functions = nlp_functions(nlp, expand=True)
    inputs = Layout([("x", n_x), ("p", nlp.n_p), ("lam_g", n_g), ("lbx", n_x), ("ubx", n_x),
                     ("lbg", n_g), ("ubg", n_g)])
    z = ca.MX.sym("z", inputs.size)
    given = inputs.split(z)
    sol = packed_outputs(transcription, {
        "x": given["x"], "f": functions["nlp_f"](given["x"], given["p"]),
        "g": functions["nlp_g"](given["x"], given["p"]), "lam_x": ca.MX(n_x, 1), "lam_g": given["lam_g"]}, given)
    layout = Layout([(name, sol[name].numel()) for name in sol])
    return Evaluator(ca.Function("newton_packed", [z], [ca.densify(layout.join(sol))])), layout
