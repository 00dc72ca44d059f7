"""The region of a plane that an `OptimalControlProblem`'s path constraints keep out, part of
the results stage: the rows g(q) <= 0 that read the configuration alone (those imposed at
every knot), as the function max_i g_i(x, y) on the plane of two coordinates, over the rows
that no other coordinate enters. `save_trajectory_plots` shades it on the path of an optimum, so
that an obstacle stated only as a constraint (a problem file of the command line) is drawn.
"""

import casadi as ca
import numpy as np

from ..optimal_control.statement.parameters import configuration_rows


def kept_out_region(problem, x, y):
    """The function g(X, Y) = max_i g_i(q) over the configuration rows of `problem`'s path
    constraints that read q[x] and q[y] alone, with q[x] = X and q[y] = Y, or None when
    there are no such rows (a row that reads another coordinate, the heading say, keeps
    out no region of the plane alone, and is left out).

    Parameters
    ----------
    problem : OptimalControlProblem
        Its path constraints' rows of q alone (`knot_rows`) with its parameter values w
        (those at q_0 for values given along the horizon).
    x, y : int
        Columns of q spanning the plane.

    Returns
    -------
    callable or None
        ``g(X, Y)`` on arrays of one shape, returning an array of that shape; g > 0 is
        the region kept out (the sign of ``path_constraints`` g <= 0).
    """
    path = problem.path_constraints
    if path is None:
        return None
    n = problem.disc.system.n
    q = ca.SX.sym("q", n)
    w = ca.SX(ca.DM(problem.parameters.knot_points(problem.disc.h)[:, 0]))      # those at q_0
    g, rows = configuration_rows(path, q, w, ca.vertcat(*[q[i] for i in range(n) if i not in (x, y)]))
    rows = [g[i] for i in rows]
    if not rows:
        return None
    plane = ca.vertcat(q[x], q[y])
    highest = ca.Function("kept_out", [plane], [ca.mmax(ca.vertcat(*rows))])

    def g(X, Y):
        X, Y = np.broadcast_arrays(np.asarray(X, dtype=float), np.asarray(Y, dtype=float))
        values = highest.map(X.size)(np.vstack([X.ravel(), Y.ravel()]))
        return np.asarray(values, dtype=float).reshape(X.shape)
    return g
