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

_SOLUTIONS = BoundedCache(16, "kkt_solutions")    # by (NLP structure, number of parameters)

ACTIVE_MULTIPLIER = 1e-6    # |multiplier| above this times (1 + the largest) marks an active bound
ACTIVE_GAP = 1e-6           # and the row or entry within this (scaled, times 1 + |bound|) of it
# -DEPENDENT_ROWS on the diagonal of the active rows' multiplier block: active rows that
# are dependent (a path row held at a knot and at the two stage points beside it, whose
# velocity is their mean) leave the multipliers non-unique and the KKT matrix singular;
# the shift picks one of them and moves dx by about DEPENDENT_ROWS |dlam|.
DEPENDENT_ROWS = 1e-12


def kkt_solution(transcription, k):
    """The Function (x, p, lam_g, active_g, active_x, d_p, d_bound) -> (dx, d_cost) of the
    scaled NLP of `transcription`, for k parameters: `solve_kkt`'s system formed and solved
    in one call; built once per NLP `structure` and k.

    Inputs: the optimum x (n_x,), p (n_p,) and lam_g (n_g,); the 0/1 masks active_g (n_g,)
    and active_x (n_x,) of the rows and entries held at a bound; the change of p (n_p, k)
    and of the bound of each entry of x (n_x, k) per unit of each parameter. Outputs: dx/dtheta
    (n_x, k) and dJ/dtheta = grad f . dx + df/dp dp (1, k). The Hessian and Jacobian are
    the solver's own (`SeparableNLP.derivatives`); the matrix of `solve_kkt` has one
    sparsity pattern whatever the active set (the masks choose its values), factored by
    CasADi's sparse QR ("qr").
    """
    def build():
        nlp, derivatives = transcription.separable, transcription.separable.derivatives()
        x, p = nlp.x, nlp.p
        n_x, n_g, n_p = x.numel(), nlp.g.numel(), p.numel()
        lam, a_g, a_x = ca.MX.sym("lam_g", n_g), ca.MX.sym("active_g", n_g), ca.MX.sym("active_x", n_x)
        d_p, d_bound = ca.MX.sym("d_p", n_p, k), ca.MX.sym("d_bound", n_x, k)
        f, grad = derivatives["nlp_grad_f"](x, p)
        jac = derivatives["nlp_jac_g"](x, p)[1]
        upper = derivatives["nlp_hess_l"](x, p, 1, lam)
        hess = upper + ca.triu(upper, False).T
        grad_l = grad + ca.mtimes(jac.T, lam)
        free = ca.diag(1 - a_x)         # the stationarity rows of the entries not held
        K = ca.blockcat([[ca.mtimes(free, hess) + ca.diag(a_x), ca.mtimes(free, jac.T)],
                         [ca.mtimes(ca.diag(a_g), jac), ca.diag(1 - a_g) - DEPENDENT_ROWS * ca.diag(a_g)]])
        rhs = ca.vertcat(ca.mtimes(ca.diag(a_x), d_bound) - ca.mtimes(free, ca.mtimes(ca.jacobian(grad_l, p), d_p)),
                         -ca.mtimes(ca.diag(a_g), ca.mtimes(ca.jacobian(nlp.g, p), d_p)))
        dx = ca.solve(K, rhs, "qr")[:n_x, :]
        d_cost = ca.mtimes(grad.T, dx) + ca.mtimes(ca.jacobian(f, p), d_p)
        return ca.Function("kkt_solution", [x, p, lam, a_g, a_x, d_p, d_bound], [dx, d_cost],
                           ["x", "p", "lam_g", "active_g", "active_x", "d_p", "d_bound"], ["dx", "d_cost"])
    return _SOLUTIONS.get((transcription.structure, k), build)


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
    """dx/dtheta, shape (n_x, k), and dJ/dtheta, shape (k,), of the scaled NLP's optimum
    (x, p, lam_g) of `transcription`, from its KKT system (`kkt_solution`).

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

    (Fiacco 1976). The multiplier nu_i of an entry held at its bound appears in the i-th
    stationarity row alone, so that row and nu are dropped and dx_i = d(bound)_i written in
    its place; the multipliers of the inactive rows of g stay zero, written as rows
    dlam_i = 0. The matrix, of size n_x + n_g, so keeps one sparsity pattern whatever
    the active set. The zero block of the active rows is shifted to -DEPENDENT_ROWS I, so
    that dependent active rows (a path row held at a knot and at the stage points beside
    it) leave the matrix regular; dx moves by about DEPENDENT_ROWS |dlam|.
    """
    k = d_p.shape[1]
    active_g, active_x, d_bound = np.zeros(lam_g.size), np.zeros(x.size), np.zeros((x.size, k))
    active_g[g_rows], active_x[x_rows], d_bound[x_rows] = 1.0, 1.0, d_x_bound
    dx, d_cost = (o.full() for o in kkt_solution(transcription, k)(x, p, lam_g, active_g, active_x,
                                                                    d_p, d_bound))
    if not (np.isfinite(dx).all() and np.isfinite(d_cost).all()):
        raise InputError("the optimum's KKT matrix is singular: the active constraints are "
                         "dependent or the optimum is not strict; no sensitivities there.")
    return dx, d_cost.ravel()
