"""Consumer 2 of the group step residual, its NLP: the `GroupOptimalControlProblem`
transcribed with the residual imposed at every step (6 rows) and the group product
R_{k+1} = R_k cay(f_k) (9 rows), both from the one `GroupStepResidual` the simulator solves.
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..._util.layout import Layout
from ...mechanics.rotations import cayley_inverse, matrix_of


@dataclass
class GroupTranscription:
    """The NLP of a GroupOptimalControlProblem.

    Attributes
    ----------
    nlp : dict
        ``{"x", "f", "g"}`` SX expressions for ``casadi.nlpsol``.
    x_layout : Layout
        Blocks ``q`` (9, N+1: the rows of R_k, column k), ``Pi`` (3, N+1), ``f`` (3, N),
        ``u`` (n_u, N).
    g_layout : Layout
        Blocks ``dynamics`` (6, N: the residual's rows), ``group`` (9, N: R_{k+1} - R_k
        cay(f_k)) and ``goal`` (3: cay^{-1}(R_goal^T R_N)).
    lbx, ubx : numpy.ndarray
        R_0 and the end momenta fixed, the rest free.
    """

    nlp: dict
    x_layout: Layout
    g_layout: Layout
    lbx: np.ndarray
    ubx: np.ndarray


def group_transcription(problem):
    """The GroupTranscription of `problem` (at its h)."""
    R, N, h = problem.residual, problem.steps, problem.disc.h
    n_u = R.n_controls
    x_layout = Layout([("q", (9, N + 1)), ("Pi", (3, N + 1)), ("f", (3, N)), ("u", (n_u, N))])
    x = ca.SX.sym("x", x_layout.size)
    q, Pi, f, u = (x_layout.unpack(x, name) for name in ("q", "Pi", "f", "u"))
    dynamics = R.function.map(N)(q[:, :-1], Pi[:, :-1], f, Pi[:, 1:], ca.SX(R.m, N), u, h)
    group = q[:, 1:] - R.reconstruction.map(N)(q[:, :-1], f)
    goal = cayley_inverse(ca.mtimes(ca.DM(problem.R_goal).T, matrix_of(q[:, -1])))
    g_layout = Layout([("dynamics", (6, N)), ("group", (9, N)), ("goal", 3)])
    nlp = {"x": x, "f": h * ca.sumsqr(u), "g": ca.vertcat(ca.vec(dynamics), ca.vec(group), goal)}
    lbx, ubx = np.full(x_layout.size, -np.inf), np.full(x_layout.size, np.inf)
    fixed = {("q", 0): problem.R_start.ravel(), ("Pi", 0): problem.Pi_start, ("Pi", N): problem.Pi_goal}
    for (name, k), value in fixed.items():
        rows = x_layout.blocks[name][1]
        at = x_layout.slice(name).start + k * rows + np.arange(rows)
        lbx[at] = ubx[at] = value
    return GroupTranscription(nlp, x_layout, g_layout, lbx, ubx)
