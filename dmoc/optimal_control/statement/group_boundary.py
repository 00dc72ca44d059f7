"""The ends of a `GroupOptimalControlProblem`, each row stated once: its goal coordinates
with free entries (None in ``x_goal``, or ``R_goal`` None) and the rows of its end momentum p_N = p_goal that
the body's momentum maps leave to impose. A free-floating robot keeps its total momentum
exactly (discrete Noether; under gravity all but the vertical linear momentum, which its
weight changes at a fixed rate), so p_0 already fixes those combinations of p_N;
imposed again they make the NLP's constraint Jacobian rank-deficient, its multipliers not
unique, and IPOPT may stop at an acceptable level on a poor point (docs/groups.md).
"""

import casadi as ca
import numpy as np

from ...errors import InputError
from .boundary import boundary_vector, pivot_columns

# the largest difference between the start's and the goal's conserved momenta, relative
# to the larger of them (at least 1), accepted as equal: the NLP's rows hold to 1e-10
MOMENTUM_TOLERANCE = 1e-10


def goal_coordinates(body, x_goal):
    """`x_goal` as the body's vector coordinates at the goal, shape (n_x,), None entries
    as NaN (free: the NLP leaves x_N,i unconstrained); required when the body has them."""
    if body.n_x == 0 and x_goal is None:
        return np.zeros(0)
    if x_goal is None:
        raise InputError(f"`x_goal` is required for {body!r}: its coordinates, shape "
                         f"({body.n_x},), None entries free.")
    return boundary_vector("x_goal", x_goal, body.n_x)


def free_goal_momentum(body, q_goal, v_goal, filled):
    """The goal's momentum M(q) v_goal (n,) at `filled` (9 + n_x,), `q_goal` (rows of R,
    then x) with its free (NaN) entries filled. InputError when a moving goal's momentum
    would depend on a free entry (through M or the constraint rows A), so that no single
    p_goal exists."""
    free = np.flatnonzero(np.isnan(q_goal))
    if free.size and np.any(v_goal):
        z = ca.SX.sym("q", q_goal.size)
        moving = ca.vertcat(ca.vec(body.generalized_mass(z)), ca.vec(body.constraint_matrix(z)))
        which = [int(i) for i in free if ca.depends_on(moving, z[int(i)])]
        if which:
            raise InputError(f"{free_entries(which)} free (None) but the goal's velocity is not "
                             f"zero, and the body's mass matrix or constraint rows depend on "
                             f"them: give them, or bring the goal to rest.")
    if not np.any(v_goal):          # at rest: zero whatever M (no evaluation)
        return np.zeros(v_goal.size)
    return np.array(body.generalized_mass(filled)) @ v_goal


def free_entries(indices):
    """The free entries of q = (rows of R, x) at `indices` as a user gave them: "`R_goal`
    is" (any of the first 9) and "`x_goal` entries [i, ...] are" (i counted in x)."""
    rotation, x = [i for i in indices if i < 9], [int(i) - 9 for i in indices if i >= 9]
    named = (["`R_goal`"] if rotation else []) + ([f"`x_goal` entries {x}"] if x else [])
    return " and ".join(named) + (" is" if named == ["`R_goal`"] else " are")


def end_rows(body, start, goal, duration):
    """Indices of the rows of p_N - p_goal - A(q_N)^T nu (n) the NLP imposes, `start` and
    `goal` each (q (9 + n_x,), p (n,)), the goal's free entries NaN: all of them, but
    for a body whose flow changes k momenta J(q, p) at a rate the controls do not touch
    (its ``momentum_map``, linear in p, and ``momentum_rate``: J_N = J_0 + N h rate) k
    fewer, those whose columns of dJ/dp at the goal are best conditioned (QR with column
    pivoting), which J_N fixes.

    Raises
    ------
    InputError
        When the goal's J is not the start's plus `duration` times the rate: no
        trajectory joins the ends; or when the goal's J depends on a free entry (the
        angular momentum about the origin on a free position at a moving goal).
    """
    momentum_map = getattr(body, "momentum_map", None)
    rows = np.arange(body.n)
    if momentum_map is None:
        return rows
    q_goal, p_goal = goal
    free = np.isnan(q_goal)
    z = ca.SX.sym("q", q_goal.size)
    at_goal = momentum_map(ca.if_else(ca.DM(free.astype(float)), z, ca.DM(np.nan_to_num(q_goal))), p_goal)
    if ca.depends_on(at_goal, z):
        raise InputError(f"{free_entries(np.flatnonzero(free))} free (None), but the goal's "
                         f"momenta J (`momentum_map`), which the start fixes, depend on them at "
                         f"its velocity: give them, or a goal velocity at which J does not read "
                         f"them (e.g. at rest).")
    J_start, J_goal = np.array(momentum_map(*start)).ravel(), np.array(ca.evalf(at_goal)).ravel()
    reached = J_start + duration * body.momentum_rate
    size = max(1.0, np.abs(reached).max(), np.abs(J_goal).max())
    if np.abs(J_goal - reached).max() > MOMENTUM_TOLERANCE * size:
        raise InputError(
            f"the body's momenta J (`momentum_map`) go from {J_start.tolist()} at the start to "
            f"{reached.tolist()} at the goal whatever the controls, but the goal's velocity "
            f"gives J = {J_goal.tolist()}: no trajectory joins the ends. Change `omega_goal`, "
            f"`x_velocity_goal` or the start's.")
    p = ca.SX.sym("p", body.n)
    dJ = np.array(ca.evalf(ca.jacobian(momentum_map(ca.DM(np.where(free, start[0], q_goal)), p), p)))
    return np.setdiff1d(rows, pivot_columns(dJ, dJ.shape[0]))
