"""The bound multipliers of the fixed variables of a DMOC NLP (consumer 2, its solver
half): the given boundary data are entries of x with lbx == ubx, which IPOPT takes out of
its problem (``fixed_variable_treatment``). Its "make_parameter" computes their
multipliers from the stationarity of the Lagrangian at every iteration, one gradient of f
each (twice the gradient calls of a re-solve, benchmarks/peers.py); "make_parameter_nodual",
dmoc's default, leaves them zero, and `FixedMultipliers` computes them in the same
operations as IPOPT's ``TNLPAdapter::ResortBoundMultipliers``, so that ``lam_x`` has the
bits "make_parameter" gave. A result's ``lam_x`` is completed on first access
(`deferred`); a warm start with the same fixed entries does not read them (`ipopt_start`).
"""

import casadi as ca
import numpy as np

from ..._util.cache import BoundedCache
from ..._util.deferred import Pending
from ..._util.numeric import Evaluator


class FixedMultipliers:
    """``lam_x`` of the fixed entries of x, in the scaled NLP IPOPT solves: ``-s_i``,
    ``s_i = df/dx_i + sum_j lam_g_j dg_j/dx_i`` (the stationarity of
    ``f + lam_g' g + lam_x' x``), each sum formed as IPOPT forms it (the gradient entry
    plus the products in the Jacobian's column order) and split as IPOPT splits it,
    ``z_U - z_L`` with ``z_L = max(0, s_i)`` and ``z_U = max(0, -s_i)`` (a zero sum gives
    +0.0).

    Parameters
    ----------
    functions : dict
        The ``nlp_grad_f`` ``(x, p) -> (f, grad_f_x)`` and ``nlp_jac_g`` ``(x, p) -> (g,
        jac_g_x)`` IPOPT evaluates (`dmoc.optimal_control.nlp.evaluation.nlp_functions`), so that
        the gradient and the Jacobian are the bits IPOPT used.
    """

    def __init__(self, functions):
        self._grad_f, self._jac_g = functions["nlp_grad_f"], functions["nlp_jac_g"]
        self._n_x = self._grad_f.nnz_in(0)
        self._terms = BoundedCache(8, "fixed_multiplier_terms")     # keyed by the fixed entries

    def __call__(self, x, p, lam_g, fixed):
        """``lam_x`` at the entries `fixed` (an int array, ascending) of the scaled NLP, at
        IPOPT's x (n_x,), p (n_p,) and lam_g (n_g,)."""
        terms, column, row = self._terms.get(fixed.tobytes(), lambda: self._build(fixed))
        values = terms(np.concatenate([x, p]))[0][:, 0]
        sums = values[:fixed.size].copy()
        # in order: each column's entries by ascending row, as IPOPT adds them
        np.add.at(sums, column, lam_g[row] * values[fixed.size:])
        return np.where(0.0 < -sums, -sums, 0.0) - np.where(0.0 < sums, sums, 0.0)

    def _build(self, fixed):
        """(`Evaluator` of ``[x; p] -> [grad_f at fixed; the Jacobian's nonzeros in the
        fixed columns]``, the position in `fixed` of each nonzero's column, its row)."""
        z = ca.MX.sym("z", self._n_x + self._grad_f.nnz_in(1))
        x, p = z[:self._n_x], z[self._n_x:]
        rows, columns = (np.array(index, dtype=int) for index in self._jac_g.sparsity_out(1).get_triplet())
        position = np.full(self._n_x, -1)
        position[fixed] = np.arange(fixed.size)
        kept = np.flatnonzero(position[columns] >= 0)       # the nonzeros in column order
        jacobian = self._jac_g(x, p)[1]
        out = ca.vertcat(self._grad_f(x, p)[1][fixed.tolist()],
                         jacobian.nz[kept.tolist()] if kept.size else ca.MX(0, 1))
        function = ca.Function("fixed_multiplier_terms", [z], [out], ["z"], ["terms"])
        return Evaluator(function), position[columns[kept]], rows[kept]


def fixed_entries(lbx, ubx):
    """The entries of x IPOPT fixes (an int array, ascending): those whose bounds as IPOPT
    sees them, scaled (``lbx / x_scale``, ``ubx / x_scale``), are equal."""
    return np.flatnonzero(lbx == ubx)


def deferred(multipliers, lam_x, fixed, scaled):
    """A result's ``lam_x`` (n_x,), in the unscaled NLP, to be completed on first access:
    `lam_x` as IPOPT returned it (zero at the entries `fixed`) with the entries `fixed`
    made by the `FixedMultipliers` `multipliers` from ``scaled = (x, p, lam_g, x_scale)``
    of the scaled NLP; `lam_x` itself when nothing is fixed."""
    if not fixed.size:
        return lam_x
    return Pending(_completed, multipliers, lam_x, fixed, scaled)


def _completed(multipliers, lam_x, fixed, scaled):
    x, p, lam_g, x_scale = scaled
    lam_x = lam_x.copy()
    lam_x[fixed] = multipliers(x, p, lam_g, fixed) / x_scale[fixed]
    return lam_x


def returned_lam_x(result):
    """(lam_x, fixed) of `result` for a reader of the entries of x that IPOPT did not fix:
    while its ``lam_x`` is not completed, IPOPT's as returned (zero at the fixed entries)
    and those entries (an int array); else ``result.lam_x`` and no entries. The entries
    not fixed are the completed ``lam_x``'s bit for bit, without the evaluation of the
    fixed ones (`FixedMultipliers`)."""
    value = vars(result).get("lam_x")
    if isinstance(value, Pending) and value.make is _completed:
        return value.args[1], value.args[2]
    return result.lam_x, np.zeros(0, dtype=int)


def ipopt_start(result, fixed):
    """The result's ``lam_x`` as the start of a solve whose fixed entries are `fixed`:
    while it is not completed and leaves exactly those entries to be computed, as IPOPT
    returned it (IPOPT drops the start multipliers of fixed entries: the same solve);
    else completed."""
    value = vars(result).get("lam_x")
    # both index arrays come from `fixed_entries` (intp): equal bytes are equal entries
    # (0.3 us against np.array_equal's 5 us)
    if isinstance(value, Pending) and value.make is _completed and value.args[2].tobytes() == fixed.tobytes():
        return value.args[1]
    return result.lam_x
