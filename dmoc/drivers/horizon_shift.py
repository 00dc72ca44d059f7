"""Warm starts of a receding-horizon controller (a driver: the optimizer in a closed loop):
the previous optimum of one NLP structure moved on by whole steps, primal and dual, on R^n
(`shifted`) and on SO(3) x R^n_x (`shifted_on_group`, the rotations moved along the
plan's own group increments and the plan carried onto the measured start)."""

import casadi as ca
import numpy as np

from .._util import deferred
from ..mechanics.rotations import cayley


def shifted(result, problem, steps=1):
    """`result` (an optimum of `problem`'s structure) moved `steps` steps on (0 < steps < N):
    the blocks of x, lam_x and lam_g indexed by step take the values of `steps` steps
    later, the last repeated."""
    T, N = problem.transcription, problem.steps
    # its trajectory, unread, stays unmade (a warm start reads x and the multipliers)
    return deferred.replace(result, x=_shifted(result.x, T.x_layout, N, steps),
                            lam_x=_shifted(result.lam_x, T.x_layout, N, steps),
                            lam_g=_shifted(result.lam_g, T.g_layout, N, steps))


def _shifted(vector, layout, steps, by):
    """`vector` with each block of N or N + 1 columns (one per step or knot; N > 1) moved
    `by` columns to the left, its last column repeated."""
    out = np.array(vector, dtype=float)
    for offset, rows, cols in layout.blocks.values():
        if cols > 1 and cols in (steps, steps + 1):
            block = out[offset:offset + rows * cols].reshape(cols, rows)     # column-major
            block[:-by] = block[by:].copy()
            block[-by:] = block[-1]
    return out


def shifted_on_group(result, T, steps, by, q_start):
    """The warm start {"x0", "lam_x0", "lam_g0"} of a `GroupTranscription` `T` of N =
    `steps` steps from its optimum `result`, moved `by` steps on (0 < by < N) and carried
    onto the start q_start = (rows of R_0, x_0), shape (9 + n_x,).

    Notes
    -----
    Every block indexed by step or knot takes the values of `by` steps later (`_shifted`),
    the last step's increment f, multipliers and controls repeated; the knots past the
    plan's end continue along that increment, R_{j+1} = R_j cay(f_{N-1}) and x_{j+1} =
    x_j + dx_{N-1}, so that each knot is R_{k+1} = R_k cay(f_k) of the one before (not
    the entries of R_N repeated). The moved plan is then carried onto the measured start
    by the rotation D = R_0 R'_0^T on the left and the translation x_0 - x'_0: R_k <- D
    R'_k, x_k <- x'_k + x_0 - x'_0. Both keep the body-frame increments F_k = R_k^T
    R_{k+1}, so the group rows hold at the warm start as they did at the optimum.
    """
    x = _shifted(result.x, T.x_layout, steps, by)
    offset, rows, _ = T.x_layout.blocks["q"]
    q = x[offset:offset + rows * (steps + 1)].reshape(steps + 1, rows)       # a view: knot k in row k
    f = T.x_layout.unpack(x, "f")[:, -1]
    F = np.array(cayley(ca.DM(f[:3])))
    for k in range(steps + 1 - by, steps + 1):
        q[k, :9] = (q[k - 1, :9].reshape(3, 3) @ F).ravel()
        q[k, 9:] = q[k - 1, 9:] + f[3:]
    D = q_start[:9].reshape(3, 3) @ q[0, :9].reshape(3, 3).T
    q[:, :9] = np.einsum("ij,kjl->kil", D, q[:, :9].reshape(-1, 3, 3)).reshape(-1, 9)
    q[:, 9:] += q_start[9:] - q[0, 9:]
    return {"x0": x, "lam_x0": _shifted(result.lam_x, T.x_layout, steps, by),
            "lam_g0": _shifted(result.lam_g, T.g_layout, steps, by)}
