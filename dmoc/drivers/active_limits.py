"""Where an optimum holds a limit (a driver, issue 40): the tests of
`dmoc.drivers.error_estimate` for the active sets that break the rule's order, a control
bound that switches inside the horizon (`switches`) and a path constraint or velocity
bound held with equality at the points where the NLP imposes it (`touches`)."""

import numpy as np

from ..discrete.knot_states import interior_points
from .interpolant_path import interpolant_path_values
from .verdict import PATH_TOLERANCE, knot_path_values, knot_velocity_bound_values


def switches(problem, traj):
    """Whether a control bound of `problem` is active at some of the control nodes of
    `traj` and not at others: a switch of the active set inside the horizon.

    Parameters
    ----------
    problem : OptimalControlProblem
        Its ``control_bounds`` (lower, upper), shapes (n_u,), infinite where unbounded.
    traj : Trajectory
        Controls `u`, shape (N, len(control_nodes) * n_u).

    Returns
    -------
    bool

    Notes
    -----
    Control i is at a bound b at a node when |u_i - b| <= 1e-6 (|b| + max_k |u_k,i|), a
    tolerance relative to the control's size and above IPOPT's distance to an active
    bound (the interior point stays 5e-10 to 3e-8 off the bound -2 on the knife edge's
    minimum time with lobatto4 at N = 20 to 320). A bound that is active everywhere or
    nowhere is no switch; one reached only between the nodes is not seen.
    """
    lower, upper = problem.control_bounds
    u = np.asarray(traj.u, dtype=float).reshape(-1, len(lower))         # (N k, n_u), in time
    size = np.max(np.abs(u), axis=0)
    for bound in (lower, upper):
        finite = np.isfinite(bound)
        b, u_b = bound[finite], u[:, finite]
        active = np.abs(u_b - b) <= 1e-6 * (np.abs(b) + size[finite])
        if np.any(active.any(axis=0) & ~active.all(axis=0)):
            return True
    return False


def touches(problem, traj):
    """Whether a path constraint or a velocity bound of `problem` holds with equality at
    a knot or an interior point of `traj`: a value g >= -PATH_TOLERANCE max(1, max |g|)
    of its row, at the points where the NLP imposes it.

    Parameters
    ----------
    problem : OptimalControlProblem
    traj : Trajectory
        An optimum of `problem`.

    Returns
    -------
    bool

    Notes
    -----
    The rows at the knots are the verdict's (`knot_path_values`,
    `knot_velocity_bound_values`); at the interior points t_k + c h
    (`dmoc.discrete.knot_states.interior_points`: the stage nodes, or the midpoint) they
    are read on the rule's interpolant (`Trajectory.sample`: q, q' and u there), with the
    parameters at c as the NLP reads them (`interpolant_path_values`). An
    interior point holds the limit where a keep-out disc is touched between knots (the
    rolling disk of `ErrorEstimate.path_active`: no knot on the disc).
    """
    nodes = np.asarray(interior_points(problem.disc.rule))
    inside = traj.sample((traj.t[:-1, None] + traj.h * nodes[None, :]).ravel())
    knot_bounds, _ = knot_velocity_bound_values(problem, traj)
    lower, upper = problem.velocity_bounds
    rows = [np.vstack([knot_bounds, np.hstack([(lower - inside.v)[:, np.isfinite(lower)],
                                               (inside.v - upper)[:, np.isfinite(upper)]])])]
    if problem.path_constraints is not None:
        between = interpolant_path_values(problem, traj, nodes)[1]
        rows.append(np.vstack([knot_path_values(problem, traj), between]))
    g = np.hstack(rows)
    return bool(g.size and np.any(g >= -PATH_TOLERANCE * np.maximum(np.abs(g).max(axis=0), 1.0)))


__all__ = ["switches", "touches"]
