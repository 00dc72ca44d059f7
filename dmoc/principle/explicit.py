"""The step residual split where one end variable is explicit: its "right" rows are
(...) - p1 (the Lagrangian forms, (43)) or (...) - q1 (39), so that variable follows from
the others and the remaining rows are the equations to solve. Both consumers use the
split, built from `StepResidual.function` itself: the simulator's Newton step solves the
rows, and the optimizer substitutes the momenta instead of carrying them as variables
where p_{k+1} follows without p_k (`substitutable`).
"""

import casadi as ca

from .._util.cache import BoundedCache
from .._util.layout import Layout

SOLVED_ROWS = ("left", "stage", "constraint")
_SPLITS = BoundedCache(64, "explicit_ends")      # keyed by (residual key, output): built once per residual


def explicit_end(residual):
    """``Function(inputs but e) -> (rows, e)`` of a StepResidual, e its formulation's
    `explicit` end variable ("p1" or "q1"): `rows` are its rows but "right" (blocks of
    `solved_rows(residual)`), e the value that zeroes the "right" rows.

    Raises RuntimeError unless the "right" rows are exactly (...) - e, so that the split is
    exact.
    """
    return _SPLITS.get((residual.key, None), lambda: _split(residual))


def substitutable(residual):
    """Whether the optimizer may substitute p_{k+1} for the momenta variables: p_{k+1} is
    the explicit end and free of p_k (true of (37) and (41); the chain p_{k+1}(p_k) of (43)
    would couple every step)."""
    if residual.formulation.explicit != "p1":
        return False
    split = explicit_end(residual)
    return not split.jac_sparsity(split.index_out("p1"), split.index_in("p0")).nnz()


def single_output(residual, name):
    """Output `name` ("rows" or the explicit end) of `explicit_end` alone, as an SX
    Function of the inputs it uses (those its dependency pattern, ``jac_sparsity``, reaches:
    what ``ca.depends_on`` tests, without a symbolic call per input)."""
    def build():
        split = explicit_end(residual)
        inputs = dict(zip(split.name_in(), split.sx_in()))
        out = split(**inputs)[name]
        index = split.index_out(name)
        used = [k for i, k in enumerate(split.name_in()) if split.jac_sparsity(index, i).nnz()]
        return ca.Function(name, [inputs[k] for k in used], [out], used, [name])
    return _SPLITS.get((residual.key, name), build)


def _split(residual):
    R, e = residual, residual.formulation.explicit
    x = {name: ca.SX.sym(name, R.inputs.numel(name)) for name in R.inputs.blocks}
    r = R.function(**x)["r"]
    right = r[R.rows["right"]]
    if not ca.is_equal(ca.jacobian(right, x[e]), -ca.SX.eye(R.n), 2):
        raise RuntimeError(f"the residual's right rows must be (...) - {e}")
    end = ca.substitute(right, x[e], ca.SX.zeros(R.n))
    rows = ca.substitute(ca.vertcat(*[r[R.rows[k]] for k in SOLVED_ROWS]), x[e], end)
    names = [k for k in R.inputs.blocks if k != e]
    return ca.Function("explicit_end", [x[k] for k in names], [rows, end], names, ["rows", e])


def solved_rows(residual):
    """Layout of the `rows` output of `explicit_end`."""
    return Layout([(k, residual.row_layout.numel(k)) for k in SOLVED_ROWS])
