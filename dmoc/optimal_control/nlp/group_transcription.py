"""Consumer 2 of the group step residual, its NLP: the `GroupOptimalControlProblem`
transcribed with the residual imposed at every step (2n + m rows) and the group product
R_{k+1} = R_k cay(f_k), x_{k+1} = x_k + dx_k (9 + n_x rows), both from the one
`GroupStepResidual` the simulator solves, and the user's path constraints g(R_k, x_k, u_k)
<= 0 at every knot.
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..._util.layout import Layout
from ...mechanics.rotations import cayley_inverse, split_configuration


@dataclass
class GroupTranscription:
    """The NLP of a GroupOptimalControlProblem.

    Attributes
    ----------
    nlp : dict
        ``{"x", "f", "g"}`` SX expressions for ``casadi.nlpsol``.
    x_layout : Layout
        Blocks ``q`` (9 + n_x, N+1: the rows of R_k then x_k, column k), ``p`` (n, N+1),
        ``f`` (n, N), ``lam`` (m, N), ``u`` (n_u, N), ``nu`` (m: the end impulse).
    g_layout : Layout
        Blocks ``dynamics`` (2n + m, N: the residual's rows), ``group`` (9 + n_x, N:
        q_{k+1} - (R_k cay(f_k), x_k + dx_k)), ``goal`` (3 + n_x: cay^{-1}(R_goal^T R_N),
        x_N - x_goal), ``end`` (n: p_N - p_goal - A(q_N)^T nu) and ``path_knots`` (rows
        of the path constraints, N + 1: g(R_k, x_k, u_k) at knot k, u_{N-1} at q_N).
    lbx, ubx : numpy.ndarray
        q_0 and p_0 fixed, the rest free.
    lbg, ubg : numpy.ndarray
        0 for every row, but -inf below the ``path_knots`` rows (g <= 0).
    dynamics_rows : Layout
        The blocks of a ``dynamics`` column (`GroupStepResidual.row_layout`), by which
        `dmoc.optimal_control.solver.violation.described` names a row.
    """

    nlp: dict
    x_layout: Layout
    g_layout: Layout
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    dynamics_rows: Layout


def group_transcription(problem):
    """The GroupTranscription of `problem` (at its h)."""
    R, N, h = problem.residual, problem.steps, problem.disc.h
    n, m, n_u, n_q = R.n, R.m, R.n_controls, R.inputs.numel("q0")
    x_layout = Layout([("q", (n_q, N + 1)), ("p", (n, N + 1)), ("f", (n, N)), ("lam", (m, N)),
                       ("u", (n_u, N)), ("nu", m)])
    x = ca.SX.sym("x", x_layout.size)
    q, p, f, lam, u, nu = (x_layout.unpack(x, name) for name in x_layout.blocks)
    dynamics = R.function.map(N)(q[:, :-1], p[:, :-1], f, p[:, 1:], lam, u, h)
    group = q[:, 1:] - R.reconstruction.map(N)(q[:, :-1], f)
    R_N, x_N = split_configuration(q[:, -1])
    goal = ca.vertcat(cayley_inverse(ca.mtimes(ca.DM(problem.R_goal).T, R_N)), x_N - problem.x_goal)
    end = p[:, -1] - problem.p_goal - ca.mtimes(R.system.constraint_matrix(q[:, -1]).T, nu)
    path = _path_knots(problem.path_constraints, q, ca.horzcat(u, u[:, -1]))
    g_layout = Layout([("dynamics", (2 * n + m, N)), ("group", (n_q, N)), ("goal", n_q - 6),
                       ("end", n), ("path_knots", (path.size1(), N + 1))])
    nlp = {"x": x, "f": h * ca.sumsqr(u),
           "g": ca.vertcat(ca.vec(dynamics), ca.vec(group), goal, end, ca.vec(path))}
    lbg, ubg = np.zeros(g_layout.size), np.zeros(g_layout.size)
    lbg[g_layout.slice("path_knots")] = -np.inf
    lbx, ubx = np.full(x_layout.size, -np.inf), np.full(x_layout.size, np.inf)
    start = np.concatenate([problem.R_start.ravel(), problem.x_start])
    for name, value in (("q", start), ("p", problem.p_start)):
        at = x_layout.slice(name).start + np.arange(value.size)      # column 0
        lbx[at] = ubx[at] = value
    return GroupTranscription(nlp, x_layout, g_layout, lbx, ubx, lbg, ubg, R.row_layout)


def _path_knots(path, q, u):
    """The rows g(R_k, x_k, u_k) of the path constraints `path` (`group_path_function`, or
    None: no rows) at the knots q (9 + n_x, N + 1) with the controls u (n_u, N + 1), shape
    (rows, N + 1)."""
    if path is None:
        return ca.SX(0, q.shape[1])
    return ca.horzcat(*[path(*split_configuration(q[:, k]), u[:, k]) for k in range(q.shape[1])])
