"""The KKT system of an optimum of the transcribed NLP, and its solution for the derivatives
of the optimum in the NLP's parameter vector p and bounds lbx, ubx (a driver: sensitivities
of an optimum, `dmoc.drivers.parametric_sensitivity`). The blocks are the exact derivatives
the solver uses (`SeparableNLP.derivatives`), in the scaled NLP IPOPT solves, and their
derivatives in p; the active set is read from the optimum's multipliers.
"""

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from ..errors import InputError

_BLOCKS = BoundedCache(16, "kkt_blocks")      # the KKT block Function, by the NLP's structure

ACTIVE_MULTIPLIER = 1e-6    # |multiplier| above this times (1 + the largest) marks an active bound
ACTIVE_GAP = 1e-6           # and the row or entry within this (scaled, times 1 + |bound|) of it


def kkt_blocks(transcription):
    """The KKT system of the scaled NLP of `transcription` at an optimum and its sparse LU
    solver, built once per NLP `structure`: (Function, Linsol).

    The Function (x, p, lam_g, active_g, active_x) -> (K, grad_f, d_grad_l_dp, d_g_dp,
    d_f_dp) gives the matrix K of `solve_kkt` (2 n_x + n_g square, one sparsity pattern
    whatever the active set: the 0/1 masks active_g (n_g,) and active_x (n_x,) choose its
    values), the cost's gradient (n_x, 1), and the derivatives in p of the Lagrangian's
    gradient d(grad f + jac^T lam_g)/dp (n_x, n_p), of g (n_g, n_p) and of f (1, n_p); the
    Hessian and Jacobian are the solver's own (`SeparableNLP.derivatives`). The Linsol
    (CasADi's sparse QR, "qr") keeps the symbolic factorization of that pattern: one
    numeric factorization per call.
    """
    def build():
        nlp, derivatives = transcription.separable, transcription.separable.derivatives()
        x, p = nlp.x, nlp.p
        n_x, n_g = x.numel(), nlp.g.numel()
        lam, a_g, a_x = ca.MX.sym("lam_g", n_g), ca.MX.sym("active_g", n_g), ca.MX.sym("active_x", n_x)
        f, grad = derivatives["nlp_grad_f"](x, p)
        jac = derivatives["nlp_jac_g"](x, p)[1]
        upper = derivatives["nlp_hess_l"](x, p, 1, lam)
        hess = upper + ca.triu(upper, False).T
        grad_l = grad + ca.mtimes(jac.T, lam)
        K = ca.blockcat([[hess, jac.T, ca.MX.eye(n_x)],
                         [ca.mtimes(ca.diag(a_g), jac), ca.diag(1 - a_g), ca.MX(n_g, n_x)],
                         [ca.diag(a_x), ca.MX(n_x, n_g), ca.diag(1 - a_x)]])
        function = ca.Function("kkt_system", [x, p, lam, a_g, a_x],
                               [K, grad, ca.jacobian(grad_l, p), ca.jacobian(nlp.g, p), ca.jacobian(f, p)],
                               ["x", "p", "lam_g", "active_g", "active_x"],
                               ["K", "grad_f", "d_grad_l_dp", "d_g_dp", "d_f_dp"])
        solver = ca.Linsol("kkt_solver", "qr", function.sparsity_out("K"))
        solver.sfact(ca.DM(function.sparsity_out("K"), 1.0))
        return function, solver
    return _BLOCKS.get(transcription.structure, build)


def active_sets(value, lower, upper, multiplier):
    """Indices of the bounds held as equalities at an optimum, and which bound: entries
    with lower == upper, and those at a bound with a multiplier of the bound's sign
    (CasADi's convention: positive at an upper bound). Returns (indices, at_upper)."""
    scale = ACTIVE_MULTIPLIER * (1 + np.abs(multiplier).max(initial=0.0))
    gap = lambda bound: np.abs(value - bound) <= ACTIVE_GAP * (1 + np.abs(np.nan_to_num(bound, posinf=0, neginf=0)))
    fixed = lower == upper
    at_upper = ~fixed & (multiplier > scale) & gap(upper)
    at_lower = ~fixed & (multiplier < -scale) & gap(lower)
    rows = np.flatnonzero(fixed | at_upper | at_lower)
    return rows, at_upper[rows]


def solve_kkt(transcription, x, p, lam_g, g_rows, x_rows, d_p, d_x_bound):
    """dx/dtheta, shape (n_x, k), and the KKT blocks (`kkt_blocks`' outputs but K, as
    ndarrays) of the scaled NLP's optimum (x, p, lam_g) of `transcription`.

    Parameters
    ----------
    transcription : Transcription
    x, p, lam_g : ndarray, shapes (n_x,), (n_p,), (n_g,)
        The optimum in the scaled NLP (x / x_scale, p, lam_g / g_scale).
    g_rows, x_rows : ndarray of int
        The active rows of g and entries of x (`active_sets`), held at their bounds.
    d_p : ndarray, shape (n_p, k)
        The change of p per unit of each of k parameters.
    d_x_bound : ndarray, shape (len(x_rows), k)
        The change of each active entry's bound per unit of each parameter (scaled).

    Notes
    -----
    With H the Lagrangian's Hessian, J_A the rows of dg/dx of the active rows and E the
    active entries of the identity, differentiating stationarity, the active rows and the
    active entries in theta gives

        [H    J_A^T  E^T] [dx   ]     [ d(grad L)/dp dp ]
        [J_A  0      0  ] [dlam ] = - [ dg_A/dp dp      ]
        [E    0      0  ] [dnu  ]     [ -d(bound)       ]

    (Fiacco 1976); the multipliers of the inactive rows and entries stay zero, which K
    writes as rows dlam_i = 0, dnu_i = 0 so that its pattern does not depend on the
    active set.
    """
    function, solver = kkt_blocks(transcription)
    n_x, n_g = x.size, lam_g.size
    active_g, active_x = np.zeros(n_g), np.zeros(n_x)
    active_g[g_rows], active_x[x_rows] = 1.0, 1.0
    K, *blocks = function(x, p, lam_g, active_g, active_x)
    blocks = [np.array(b) for b in blocks]
    rhs = np.zeros((2 * n_x + n_g, d_p.shape[1]))
    rhs[:n_x] = -blocks[1] @ d_p
    rhs[n_x + g_rows] = -(blocks[2] @ d_p)[g_rows]
    rhs[n_x + n_g + x_rows] = d_x_bound
    solution = _solved(solver, K, rhs)
    return solution[:n_x], blocks


def _solved(solver, K, rhs):
    """K^-1 rhs by `solver`; InputError when K is singular (no local sensitivities)."""
    try:
        solver.nfact(K)
        solution = np.array(solver.solve(K, ca.DM(rhs)))
    except RuntimeError:                # a factorization that failed
        solution = np.full(rhs.shape, np.nan)
    if not np.isfinite(solution).all():
        raise InputError("the optimum's KKT matrix is singular: the active constraints are "
                         "dependent or the optimum is not strict; no sensitivities there.")
    return solution
