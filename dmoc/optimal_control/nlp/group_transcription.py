"""Consumer 2 of the group step residual, its NLP: the `GroupOptimalControlProblem`
transcribed with the residual imposed at every step (2n + m rows) and the group product
R_{k+1} = R_k cay(f_k), x_{k+1} = x_k + dx_k (9 + n_x rows), both from the one
`GroupStepResidual` the simulator solves, and the user's path constraints g(R_k, x_k, u_k)
<= 0 at every knot. Stated as the terms of a partially separable NLP, as a problem on R^n
is (`dmoc.optimal_control.nlp.separable`): one step term mapped over the steps, the goal
term and the path term mapped over the knots, their Functions and derivatives built once
per body (and path constraints), whatever N, h and the end data.
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..._util.layout import Layout
from ...mechanics.rotations import cayley_inverse, matrix_of, split_configuration
from .separable import SeparableNLP, function_key
from .terms import block_indices, slot_term


@dataclass
class GroupTranscription:
    """The NLP ``min f(x, p) s.t. lbg <= g(x, p) <= ubg, lbx <= x <= ubx`` of a
    GroupOptimalControlProblem.

    Attributes
    ----------
    separable : SeparableNLP
        The NLP as terms, with its assembled exact derivatives (``separable.derivatives()``).
    x_layout : Layout
        Blocks ``q`` (9 + n_x, N+1: the rows of R_k then x_k, column k), ``p`` (n, N+1),
        ``f`` (n, N), ``lam`` (m, N), ``u`` (n_u, N), ``nu`` (m: the end impulse).
    p_layout : Layout
        Blocks ``h`` (1), ``R_goal`` (9, its rows; 0 when free), ``x_goal`` (its given entries),
        ``p_goal`` (its `end_rows`).
    g_layout : Layout
        Blocks ``dynamics`` (2n + m, N: the residual's rows), ``group`` (9 + n_x, N:
        q_{k+1} - (R_k cay(f_k), x_k + dx_k)), ``goal`` (cay^{-1}(R_goal^T R_N), 3 rows
        unless R_goal is free; x_N - x_goal at its given entries), ``end`` (the problem's `end_rows` of p_N -
        p_goal - A(q_N)^T nu) and ``path_knots`` (rows
        of the path constraints, N + 1: g(R_k, x_k, u_k) at knot k, u_{N-1} at q_N).
    p : numpy.ndarray, shape (p_layout.size,)
        The values of p: h and the goal's data.
    lbx, ubx : numpy.ndarray
        q_0 and p_0 fixed, the rest free.
    lbg, ubg : numpy.ndarray
        0 for every row, but -inf below the ``path_knots`` rows (g <= 0).
    dynamics_rows : Layout
        The blocks of a ``dynamics`` column (`GroupStepResidual.row_layout`), by which
        `dmoc.optimal_control.solver.violation.described` names a row.
    x_scale, g_scale : numpy.ndarray
        Ones, shapes (x_layout.size,) and (g_layout.size,): the NLP is not scaled (the
        IPOPT solver of `dmoc.optimal_control.solver.ipopt` reads them).
    """

    separable: SeparableNLP
    x_layout: Layout
    p_layout: Layout
    g_layout: Layout
    p: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    dynamics_rows: Layout
    x_scale: np.ndarray
    g_scale: np.ndarray

    @property
    def nlp(self):
        """``{"x", "p", "f", "g"}`` CasADi MX expressions of the mapped terms, for
        ``casadi.nlpsol`` (with p = `p`)."""
        return {k: getattr(self.separable, k) for k in ("x", "p", "f", "g")}

    @property
    def structure(self):
        """A key of the NLP by value (`SeparableNLP.key`): transcriptions with equal keys
        differ at most in the bounds and p."""
        return self.separable.key


def group_transcription(problem):
    """The GroupTranscription of `problem` (at its h)."""
    R, N = problem.residual, problem.steps
    n, m, n_u, n_q = R.n, R.m, R.n_controls, R.inputs.numel("q0")
    path = problem.path_constraints
    x_layout = Layout([("q", (n_q, N + 1)), ("p", (n, N + 1)), ("f", (n, N)), ("lam", (m, N)),
                       ("u", (n_u, N)), ("nu", m)])
    given, ends = np.flatnonzero(np.isfinite(problem.x_goal)), problem.end_rows
    turn = 0 if problem.R_goal is None else 3          # the rotation's goal rows
    p_layout = Layout([("h", 1), ("R_goal", 3 * turn), ("x_goal", given.size), ("p_goal", ends.size)])
    g_layout = Layout([("dynamics", (2 * n + m, N)), ("group", (n_q, N)), ("goal", turn + given.size),
                       ("end", ends.size), ("path_knots", (0 if path is None else path.numel_out(0), N + 1))])
    layouts = (x_layout, p_layout, g_layout)
    scales = (np.ones(x_layout.size), np.ones(g_layout.size))
    terms = [_step_term(problem, layouts, scales), _goal_term(problem, layouts, scales)]
    if g_layout.numel("path_knots"):
        terms.append(_path_term(problem, layouts, scales))
    separable = SeparableNLP(x_layout.size, p_layout.size, g_layout.size, terms)
    lbg, ubg = np.zeros(g_layout.size), np.zeros(g_layout.size)
    lbg[g_layout.slice("path_knots")] = -np.inf
    lbx, ubx = np.full(x_layout.size, -np.inf), np.full(x_layout.size, np.inf)
    start = np.concatenate([problem.R_start.ravel(), problem.x_start])
    for name, value in (("q", start), ("p", problem.p_start)):
        at = x_layout.slice(name).start + np.arange(value.size)      # column 0
        lbx[at] = ubx[at] = value
    p = np.concatenate([[problem.disc.h], [] if problem.R_goal is None else problem.R_goal.ravel(),
                        problem.x_goal[given], problem.p_goal[ends]])
    return GroupTranscription(separable, x_layout, p_layout, g_layout, p, lbx, ubx, lbg, ubg,
                              R.row_layout, *scales)


def _step_term(problem, layouts, scales):
    """Step k: the cost h |u_k|^2 and the rows (the residual at (q_k, p_k, f_k, p_{k+1},
    lam_k, u_k, h); q_{k+1} - reconstruction(q_k, f_k))."""
    R = problem.residual
    (X, P, G) = (block_indices(lay) for lay in layouts)
    slots = {"q0": ("x", X["q"][:, :-1]), "q1": ("x", X["q"][:, 1:]), "p0": ("x", X["p"][:, :-1]),
             "p1": ("x", X["p"][:, 1:]), "f": ("x", X["f"]), "lam": ("x", X["lam"]),
             "u": ("x", X["u"]), "h": ("p", P["h"])}

    def body(s):        # the residual and R_k cay(f_k) from one graph (`GroupStepResidual.stepped`)
        rows, q1 = R.stepped(s["q0"], s["p0"], s["f"], s["p1"], s["lam"], s["u"], s["h"])
        return s["h"] * ca.sumsqr(s["u"]), ca.vertcat(rows, s["q1"] - q1)
    return slot_term("group_step", slots, body, np.vstack([G["dynamics"], G["group"]]),
                     ("group_step", R.key), scales, plain=True)


def _goal_term(problem, layouts, scales):
    """The goal rows at q_N (cay^{-1}(R_goal^T R_N), x_N - x_goal at the given entries)
    and the end momentum p_N - p_goal - A(q_N)^T nu at the `end_rows`, the goal's data
    read from p."""
    A = problem.residual.system.constraint_matrix
    given, ends = np.flatnonzero(np.isfinite(problem.x_goal)).tolist(), problem.end_rows.tolist()
    turned = problem.R_goal is not None
    (X, P, G) = (block_indices(lay) for lay in layouts)
    slots = {"q": ("x", X["q"][:, -1:]), "p": ("x", X["p"][:, -1:]), "nu": ("x", X["nu"]),
             **{name: ("p", P[name]) for name in ("R_goal", "x_goal", "p_goal")}}

    def body(s):
        R_N, x_N = split_configuration(s["q"])
        goal = cayley_inverse(ca.mtimes(matrix_of(s["R_goal"]).T, R_N)) if turned else ca.SX(0, 1)
        end = s["p"] - ca.mtimes(A(s["q"]).T, s["nu"])
        return 0, ca.vertcat(goal, x_N[given] - s["x_goal"], end[ends] - s["p_goal"])
    return slot_term("group_goal", slots, body, np.vstack([G["goal"], G["end"]]),
                     ("group_goal", problem.residual.key, turned, tuple(given), tuple(ends)), scales,
                     plain=True)


def _path_term(problem, layouts, scales):
    """The path rows g(R_k, x_k, u_k) at knot k = 0 ... N, u_{N-1} at q_N."""
    path = problem.path_constraints
    (X, P, G) = (block_indices(lay) for lay in layouts)
    slots = {"q": ("x", X["q"]), "u": ("x", np.hstack([X["u"], X["u"][:, -1:]]))}

    def body(s):
        return 0, ca.vec(path(*split_configuration(s["q"]), s["u"]))
    return slot_term("group_path", slots, body, G["path_knots"], ("group_path", function_key(path)), scales)
