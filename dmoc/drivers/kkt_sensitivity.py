"""The KKT system of an optimum of the transcribed NLP, and its solution for the derivatives
of the optimum in the NLP's parameter vector p and bounds lbx, ubx (a driver: sensitivities
of an optimum, `dmoc.drivers.parametric_sensitivity`): the active set read from the
optimum's multipliers, the derivatives of the KKT conditions in p, the matrix's solution
(`dmoc.optimal_control.nlp.kkt_matrix`).
"""

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from .._util.numeric import Evaluator
from ..errors import InputError
from ..optimal_control.nlp.evaluation import nlp_functions
from ..optimal_control.nlp.kkt_matrix import BACKWARD_ERROR, kkt_layout, kkt_solution, kkt_system

_DIRECTIONS = BoundedCache(16, "kkt_directions")    # by (NLP structure, number of parameters)

ACTIVE_MULTIPLIER = 1e-6    # |multiplier| above this times (1 + the largest) marks an active bound
ACTIVE_GAP = 1e-6           # and the row or entry within this (scaled, times 1 + |bound|) of it


def kkt_directions(transcription, k):
    """The Evaluator of ``(x, p, lam_g, d_p) -> (r, d_f)``: minus the derivatives of the
    Lagrangian's gradient and of g along the k columns of d_p (n_p, k), stacked, shape
    (n_x + n_g, k), and those of f, (1, k) (forward mode); built once per NLP `structure`
    and k, called only for data that move p."""
    def build():
        nlp = transcription.separable
        functions = nlp_functions(nlp, expand=True)
        x, p, lam, d_p = nlp.x, nlp.p, ca.MX.sym("lam_g", nlp.n_g), ca.MX.sym("d_p", nlp.n_p, k)
        f, grad = functions["nlp_grad_f"](x, p)
        g, jac = functions["nlp_jac_g"](x, p)
        moved = ca.jtimes(ca.vertcat(grad + ca.mtimes(jac.T, lam), g, f), p, d_p)
        n = nlp.n_x + nlp.n_g
        return Evaluator(ca.Function("kkt_directions", [x, p, lam, d_p], [-moved[:n, :], moved[n:, :]],
                                     ["x", "p", "lam_g", "d_p"], ["r", "d_f"]))
    return _DIRECTIONS.get((transcription.structure, k), build)


def active_sets(value, lower, upper, multiplier):
    """Indices of the bounds held as equalities at an optimum, and which bound: entries
    with lower == upper, and those at a bound with a multiplier of the bound's sign
    (CasADi's convention: positive at an upper bound). Returns (indices, at_upper)."""
    scale = ACTIVE_MULTIPLIER * (1 + np.abs(multiplier).max(initial=0.0))
    gap = lambda bound: np.abs(value - bound) <= ACTIVE_GAP * (1 + np.where(np.isfinite(bound), np.abs(bound), 0.0))
    fixed = lower == upper
    at_upper = ~fixed & (multiplier > scale) & gap(upper)
    at_lower = ~fixed & (multiplier < -scale) & gap(lower)
    rows = np.flatnonzero(fixed | at_upper | at_lower)
    return rows, at_upper[rows]


def solve_kkt(transcription, x, lam_g, lam_x, d_p, d_lower, d_upper):
    """dx/dtheta, shape (n_x, k), dJ/dtheta, shape (k,), and the active rows of g and
    entries of x, of the scaled NLP's optimum of `transcription`, from its KKT system.

    Parameters
    ----------
    transcription : Transcription
    x, lam_g, lam_x : ndarray, shapes (n_x,), (n_g,), (n_x,)
        The optimum in the scaled NLP (x / x_scale, lam_g / g_scale, lam_x * x_scale), at
        the transcription's p.
    d_p : ndarray, shape (n_p, k)
        The change of p per unit of each of k parameters.
    d_lower, d_upper : ndarray, shapes (n_x, k)
        The change of the scaled bounds lbx / x_scale, ubx / x_scale per unit of each
        parameter.

    Returns
    -------
    dx : ndarray, shape (n_x, k)
    d_cost : ndarray, shape (k,)
    g_rows, x_rows : ndarray of int
        The rows of g and entries of x held at a bound (`active_sets`).

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
    dlam_i = 0. The matrix so keeps one sparsity pattern whatever the active set
    (`dmoc.optimal_control.nlp.kkt_matrix.KKTSystem`), and its factorization one symbolic
    analysis; the entries fixed by lbx == ubx (the boundary data) are left out of it, their
    columns times their bounds' change moved to the right side. The zero block of the
    active rows is shifted to -DEPENDENT_ROWS I (`dmoc.optimal_control.nlp.kkt_matrix`), so that
    dependent active rows (a path row held at a knot and at the stage points beside it)
    leave the matrix regular; dx moves by about DEPENDENT_ROWS
    |dlam|. Of the two methods of `kkt_solution` the one whose factors hold fewer nonzeros
    (`kkt_layout`) goes first: the LDL^T of the symmetric matrix shifted to quasi-definite,
    refined against the exact one (the rolling disk: its QR's factors hold 7 times as many
    nonzeros as its LDL^T's), accepted when the backward error of every column and of a
    probe is at most BACKWARD_ERROR, else the sparse QR (the knife edge). A singular matrix
    stalls the probe's refinement and fails the QR (a diagonal entry of R below 1e-12): it
    is refused, naming the entries of x largest along the probe's solution. The
    derivatives in p (forward mode, `kkt_directions`) are formed only when d_p is not zero
    (boundary data other than q_start and p_start fix bounds alone), and columns whose
    right side is zero (a free entry) are not solved.

    Raises
    ------
    InputError
        The KKT matrix is singular.
    """
    T, k = transcription, d_p.shape[1]
    g, grad, values = kkt_system(T).blocks(x, T.p, lam_g)
    lbg, ubg = T.scaled_g_bounds
    g_rows, _ = active_sets(g[:, 0], lbg, ubg, lam_g)
    lbx, ubx = T.lbx / T.x_scale, T.ubx / T.x_scale
    x_rows, at_upper = active_sets(x, lbx, ubx, lam_x)
    active_x, active_g, d_bound = np.zeros(x.size), np.zeros(lam_g.size), np.zeros((x.size, k))
    active_x[x_rows], active_g[g_rows] = 1.0, 1.0
    d_bound[x_rows] = np.where(at_upper[:, None], d_upper[x_rows], d_lower[x_rows])
    if d_p.any():
        r, d_f = kkt_directions(T, k)(x, T.p, lam_g, d_p)
        moving = np.flatnonzero(d_bound.any(axis=0) | r.any(axis=0))   # the columns to solve for
        r = r[:, moving]
    else:
        moving = np.flatnonzero(d_bound.any(axis=0))                    # the others' dx is 0
        r, d_f = np.zeros((x.size + lam_g.size, moving.size)), np.zeros((1, k))
    fixed = np.flatnonzero(lbx == ubx)
    bounded = np.flatnonzero((np.isfinite(lbx) | np.isfinite(ubx)) & (lbx != ubx))
    equalities = bounded.size == 0 and bool(np.all(lbg == ubg))
    args = (values, active_x, active_g, d_bound[:, moving], r)
    solution = direction = None
    for method in dict.fromkeys((kkt_layout(T, fixed)[-1], "qr")):
        try:
            solution, *error = kkt_solution(T, moving.size, fixed, bounded, equalities, method)(*args)
        except RuntimeError:            # the QR's R has a diagonal entry below CasADi's eps
            solution = None
            break
        if method == "qr":
            break
        direction = solution[:, -1]     # the probe's, along a null direction when singular
        if error[0] <= BACKWARD_ERROR:
            solution = solution[:, :-1]
            break
    if solution is None or not np.isfinite(solution).all():
        where = "" if direction is None else f" (largest in {_named(T.x_layout, direction)})"
        raise InputError("the optimum's KKT matrix (the Lagrangian's Hessian with the active constraints' "
                         "Jacobian) is singular: the active constraints are dependent or the optimum is not "
                         "strict, as along a direction of x in which neither the cost nor the constraints "
                         f"change{where}; no sensitivities there.")
    dx = np.zeros((x.size, k))
    dx[:, moving] = solution
    return dx, grad[:, 0] @ dx + d_f[0], g_rows, x_rows


def _named(layout, direction):
    """The entries of x where `direction` (n_x,) is largest (or not finite), three at
    most, as 'block[row, column]' of `layout`."""
    largest = np.argsort(-np.nan_to_num(np.abs(direction), nan=np.inf))[:3]
    return ", ".join("{}[{}, {}]".format(*layout.locate(i)) for i in largest)
