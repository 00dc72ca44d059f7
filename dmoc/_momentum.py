"""The step residual split where p_{k+1} is explicit: its "right" rows are (...) - p1, so
p_{k+1} follows from (q_k, q_{k+1}, lam_k, s_k, u_k, h) and the other rows are the equations
to solve. Both consumers use the split, built from `StepResidual.function` itself: the
simulator's Newton step solves the rows, the optimizer substitutes the momenta instead
of carrying them as variables.
"""

import casadi as ca

from .layout import Layout

SOLVED_ROWS = ("left", "stage", "constraint")


def explicit_momentum(residual):
    """``Function(q0, p0, q1, lam, s, u, h) -> (rows, p1)`` of a StepResidual: `rows` are
    its rows but "right" (blocks of `solved_rows(residual)`), `p1` the p_{k+1} that zeroes
    the "right" rows.

    Raises RuntimeError unless the "right" rows are exactly (...) - p1 with (...) free of
    p0 (true of (37) and (41)), so that the split is exact.
    """
    R = residual
    x = {name: ca.SX.sym(name, R.inputs.numel(name)) for name in R.inputs.blocks}
    r = R.function(**x)["r"]
    right = r[R.rows["right"]]
    if not ca.is_equal(ca.jacobian(right, x["p1"]), -ca.SX.eye(R.n), 2) or ca.depends_on(right, x["p0"]):
        raise RuntimeError("the residual's right rows must be (...) - p1 with (...) free of p0")
    rows = ca.vertcat(*[r[R.rows[k]] for k in SOLVED_ROWS])
    zero = ca.SX.zeros(R.n)
    names = [k for k in R.inputs.blocks if k != "p1"]
    return ca.Function("explicit_momentum", [x[k] for k in names],
                       [ca.substitute(rows, x["p1"], zero), ca.substitute(right, x["p1"], zero)],
                       names, ["rows", "p1"])


def solved_rows(residual):
    """Layout of the `rows` output of `explicit_momentum`."""
    return Layout([(k, residual.row_layout.numel(k)) for k in SOLVED_ROWS])
