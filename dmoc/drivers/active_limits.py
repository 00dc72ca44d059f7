"""Where an optimum holds a limit (a driver, issue 40): the tests of
`dmoc.drivers.error_estimate` for the active sets that break the rule's order, a control
bound that switches inside the horizon (`switches`) and a path constraint or velocity
bound held with equality at the points where the NLP imposes it (`touches`), and the cost
of the interior point's distance from the bounds it holds (`barrier_offset`)."""

import numpy as np

from ..discrete.knot_states import interior_points
from ..optimal_control.solver.fixed_multipliers import returned_lam_x
from .interpolant_path import interpolant_path_values
from .verdict import PATH_TOLERANCE, knot_path_values, knot_velocity_bound_values


def switches(problem, result):
    """Whether a control bound of `problem` is active at some of the control nodes of the
    optimum `result` and not at others: a switch of the active set inside the horizon.

    Parameters
    ----------
    problem : OptimalControlProblem
        Its ``control_bounds`` (lower, upper), shapes (n_u,), infinite where unbounded.
    result : OptimizationResult
        Its trajectory's controls `u`, shape (N, len(control_nodes) * n_u), and the
        multipliers of the NLP's bounds `lam_x` (positive at an upper bound, negative at a
        lower one; None, as in a file written without them: the distance alone).

    Returns
    -------
    bool

    Notes
    -----
    Control i is at a bound b at a node when |u_i - b| <= 1e-6 S_i, S_i = |b| + max_k
    |u_k,i|, or when |u_i - b| / S_i <= |lam_i| / max_k |lam_k,i| with lam_i the bound's
    multiplier there (of the bound's sign; the largest over that bound's nodes). The
    interior point stays mu / |lam_i| off an active bound, which grows as the cost per
    step shrinks: on the knife edge's minimum time (|u| <= 1, lobatto4) 5e-10 to 3e-8 at
    N = 20 to 320, but with |u_0| in [-0.5, 1] and a cost of 1e-4 per second 1e-5 of the
    range at N = 52, where the distance alone found no node at its bound and the estimate
    assumed order 6 (2.1e-6 against a true 5.8e-5). Off a bound the multiplier is mu /
    distance, 1e-4 of the largest or less, far below the relative distance. A bound that
    is active everywhere or nowhere is no switch; one reached only between the nodes is
    not seen.
    """
    lower, upper = problem.control_bounds
    if not (np.isfinite(lower).any() or np.isfinite(upper).any()):
        return False
    traj, layout = result.trajectory, problem.transcription.x_layout
    u = np.asarray(traj.u, dtype=float).reshape(-1, len(lower))         # (N k, n_u), in time
    lam = np.zeros_like(u) if result.lam_x is None else \
        layout.unpack(np.asarray(result.lam_x, dtype=float), "u").T.reshape(u.shape)
    size = np.max(np.abs(u), axis=0)
    for bound, sign in ((lower, -1.0), (upper, 1.0)):
        finite = np.isfinite(bound)
        b, u_b, held = bound[finite], u[:, finite], np.maximum(sign * lam[:, finite], 0.0)
        distance = np.abs(u_b - b) / (np.abs(b) + size[finite])
        largest = held.max(axis=0, initial=0.0)
        active = (distance <= 1e-6) | (held > 0) & (distance * largest <= held)
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
    rolling disk of `ErrorEstimate.path_active`: no knot on the disc). Without path
    constraints and finite velocity bounds there are no rows: False, nothing evaluated
    (the knots' end velocities and the interpolant at the interior points were a sixth of
    the accuracy loop's estimate on the rolling disk, lobatto4; callgrind, issue 41).
    """
    lower, upper = problem.velocity_bounds
    if problem.path_constraints is None and not (np.isfinite(lower).any() or np.isfinite(upper).any()):
        return False
    nodes = np.asarray(interior_points(problem.disc.rule))
    inside = traj.sample((traj.t[:-1, None] + traj.h * nodes[None, :]).ravel())
    knot_bounds, _ = knot_velocity_bound_values(problem, traj)
    rows = [np.vstack([knot_bounds, np.hstack([(lower - inside.v)[:, np.isfinite(lower)],
                                               (inside.v - upper)[:, np.isfinite(upper)]])])]
    if problem.path_constraints is not None:
        between = interpolant_path_values(problem, traj, nodes)[1]
        rows.append(np.vstack([knot_path_values(problem, traj), between]))
    g = np.hstack(rows)
    return bool(g.size and np.any(g >= -PATH_TOLERANCE * np.maximum(np.abs(g).max(axis=0), 1.0)))


def barrier_offset(problem, result):
    """The part of an optimum's cost that is IPOPT's, not the grid's: sum_i |lam_i| s_i /
    |J| over the bounds of the NLP vector x that hold it (lam_i the bound's multiplier,
    positive at an upper bound and negative at a lower one; s_i the distance of x_i from
    that bound), relative to the cost J (absolute where J = 0).

    Parameters
    ----------
    problem : OptimalControlProblem
    result : OptimizationResult
        An optimum of `problem`: its `x`, `lam_x` and `cost`.

    Returns
    -------
    float

    Notes
    -----
    The interior point stays s_i = mu / |lam_i| off every bound it holds, so it solves the
    problem with those bounds moved inwards by s_i, whose cost differs by sum_i |lam_i| s_i
    to first order (the multipliers are the cost's derivatives in the bounds). The offset
    grows as the cost per step shrinks: on the knife edge's minimum time with -0.5 <= u0
    <= 1 and a cost of 1e-4 per second, lobatto4 on 52 steps, 7.7e-6, where T_52 moves by
    1.15e-5 of T* when IPOPT's tol goes from 1e-10 to 1e-13 (offset 7.7e-9); with a cost of
    1 per second, 7.7e-10. Bounds fixed to a value (lbx = ubx, the boundary data) hold
    nothing here. 0 for a result without `x` or `lam_x` (a file written without them).
    Where IPOPT fixed exactly the entries with lbx = ubx, their multipliers are not
    evaluated (`returned_lam_x`): they count for nothing here.
    """
    T = problem.transcription
    lam, fixed = returned_lam_x(result)
    if fixed.size and not np.array_equal(T.lbx[fixed], T.ubx[fixed]):
        lam = result.lam_x
    if lam is None or result.x is None:
        return 0.0
    lam, x = np.asarray(lam, dtype=float), np.asarray(result.x, dtype=float)
    distance = np.where(lam > 0, T.ubx - x, x - T.lbx)
    held = (T.lbx < T.ubx) & (lam != 0) & np.isfinite(distance)
    return float(np.sum(np.abs(lam[held]) * distance[held]) / (abs(result.cost) or 1.0))


__all__ = ["switches", "touches", "barrier_offset"]
