"""The step residual split where p_{k+1} is explicit: its "right" rows are (...) - p1, so
p_{k+1} follows from (q_k, q_{k+1}, lam_k, s_k, u_k, h) and the other rows are the equations
to solve. Both consumers use the split, built from `StepResidual.function` itself: the
simulator's Newton step solves the rows, the optimizer substitutes the momenta instead
of carrying them as variables.
"""

import casadi as ca

from ._cache import BoundedCache
from .layout import Layout

SOLVED_ROWS = ("left", "stage", "constraint")
_SPLITS = BoundedCache(64)      # keyed by (residual key, output): built once per residual


def explicit_momentum(residual):
    """``Function(q0, p0, q1, lam, s, u, h) -> (rows, p1)`` of a StepResidual: `rows` are
    its rows but "right" (blocks of `solved_rows(residual)`), `p1` the p_{k+1} that zeroes
    the "right" rows.

    Raises RuntimeError unless the "right" rows are exactly (...) - p1 with (...) free of
    p0 (true of (37) and (41)), so that the split is exact.
    """
    return _SPLITS.get((residual.key, None), lambda: _split(residual))


def single_output(residual, name):
    """Output `name` ("rows" or "p1") of `explicit_momentum` alone, as an SX Function of
    the inputs it uses (p1 takes no p0)."""
    def build():
        split = explicit_momentum(residual)
        inputs = dict(zip(split.name_in(), split.sx_in()))
        out = split(**inputs)[name]
        used = [k for k, x in inputs.items() if ca.depends_on(out, x)]
        return ca.Function(name, [inputs[k] for k in used], [out], used, [name])
    return _SPLITS.get((residual.key, name), build)


def _split(residual):
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
