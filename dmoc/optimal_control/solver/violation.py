"""How far a point of the DMOC NLP is from feasible (consumer 2, its solver half): the
largest violation of the rows' bounds and the first row that has it, as one CasADi
Function, which the packed IPOPT call evaluates at IPOPT's last iterate
(`dmoc.optimal_control.solver.ipopt.PackedSolver`) and `most_violated` at any g; and that row named by
its group (dynamics at step k, boundary, path).
"""

import casadi as ca

from ..._util import typed_ops
from ..._util.cache import BoundedCache
from ..._util.numeric import Evaluator

_EVALUATORS = BoundedCache(16, "violations")     # keyed by the number of rows: `most_violated`


def largest_violation(n_g):
    """Function ``(g, lbg, ubg) -> (largest, row)`` over n_g rows (n_g >= 1): the largest
    of max(lbg_i - g_i, g_i - ubg_i) over the rows, a row where either difference is NaN
    (g NaN, or g and its bound infinite alike) counting as violated by inf, and the first
    row that has it; (0, 0) when no row is violated. ``row`` is a float holding an
    integer."""
    g, lbg, ubg = (ca.MX.sym(name, n_g) for name in ("g", "lbg", "ubg"))
    below, above = typed_ops.minus(lbg, g), typed_ops.minus(g, ubg)
    violation = _if_else(typed_ops.plus(_is_nan(below), _is_nan(above)), ca.MX(ca.inf),
                         ca.MX.binary(ca.OP_FMAX, below, above))
    worst = ca.mmax(violation)
    violated, zero = typed_ops.less(0.0, worst), ca.MX(0.0)
    return ca.Function("largest_violation", [g, lbg, ubg],
                       [_if_else(violated, worst, zero),
                        _if_else(violated, ca.find(typed_ops.equal(violation, worst)), zero)],
                       ["g", "lbg", "ubg"], ["largest", "row"])


def _if_else(condition, if_true, if_false):
    """MX: ``ca.if_else(condition, if_true, if_false)``, its nodes if_else_zero(c, a) +
    if_else_zero(!c, b) made through the typed entry points (`typed_ops`)."""
    return typed_ops.plus(ca.MX.binary(ca.OP_IF_ELSE_ZERO, condition, if_true),
                          ca.MX.binary(ca.OP_IF_ELSE_ZERO, typed_ops.logic_not(condition), if_false))


def _is_nan(v):
    """MX: 1 where v is NaN, else 0 (``v != v`` would be simplified to 0 symbolically;
    NaN <= inf is false, every other value's true)."""
    return typed_ops.logic_not(typed_ops.less_equal(v, ca.inf))


def most_violated(transcription, g):
    """(largest bound violation, its description) over the constraint vector g (unscaled)
    of `transcription` (`largest_violation`; "none" without rows)."""
    if g.size == 0:
        return worst(transcription, 0.0, 0)
    largest = _EVALUATORS.get(g.size, lambda: Evaluator(largest_violation(g.size)))
    value, row = largest(g, transcription.lbg, transcription.ubg)
    return worst(transcription, value[0, 0], row[0, 0])


def worst(transcription, largest, row):
    """(largest violation, its row `row` described): `largest_violation`'s outputs for
    the stats of a solve; (0.0, "none") when `transcription` has no rows."""
    if not transcription.g_layout.size:
        return 0.0, "none"
    return float(largest), described(transcription, int(row))


def described(transcription, row):
    """The row `row` of the constraint vector of `transcription` by its group: "dynamics
    at step k (block row r)", "path constraint i at step k", "path constraint i at knot k",
    "velocity bound of v[i] at knot k" (with " (point j)" after "step k" where a step has
    several interior points: `dmoc.discrete.knot_states.interior_points`), "group product
    at step k (row r)" (q_{k+1} = R_k cay(f_k) of a problem on SO(3): `group_transcription`)
    or "boundary condition 'group' row r"."""
    group, block_row, col = transcription.g_layout.locate(row)
    if group == "dynamics":
        name, row_in_block, _ = transcription.dynamics_rows.locate(block_row)     # blocks of one column
        return f"dynamics at step {col} ({name} row {row_in_block})"
    if group == "path":
        rows, per_step = (transcription.g_layout.blocks[name][1] for name in ("path_knots", "path"))
        point = f" (point {block_row // rows})" if per_step > rows else ""
        return f"path constraint {block_row % rows} at step {col}{point}"
    if group == "path_knots":
        return f"path constraint {block_row} at knot {col}"
    if group in ("velocity_steps", "velocity_knots"):
        bounded = transcription.velocity_bounded
        several = transcription.g_layout.blocks["velocity_steps"][1] > len(bounded)
        point = f" (point {block_row // len(bounded)})" if several else ""
        where = f"knot {col}" if group == "velocity_knots" else f"step {col}{point}"
        return f"velocity bound of v[{bounded[block_row % len(bounded)]}] at {where}"
    if group == "control_hull":
        hulled = transcription.hulled_controls
        return (f"control bound of u[{hulled[block_row % len(hulled)]}] between the nodes of "
                f"step {col} (Bernstein coefficient {block_row // len(hulled) + 1})")
    if group == "group":
        return f"group product at step {col} (row {block_row})"
    return f"boundary condition '{group}' row {block_row}"


def on_bound(x, lbx, ubx):
    """MX: the number of entries of x with lbx < ubx that sit on one of their bounds."""
    return ca.sum1(typed_ops.times(typed_ops.less(lbx, ubx),
                                   typed_ops.plus(typed_ops.equal(x, lbx), typed_ops.equal(x, ubx))))

