"""How the momenta p_0 ... p_N enter the DMOC NLP, chosen once as a value (consumer 2 of the
step residual): carried as variables, every row of the step residual of (37)/(41) imposed,
or substituted, only p_0 a variable and p_{k+1} = D2 L_d + f_d^+ (- A^T lam for (-)) the
explicit end of step k (`dmoc.principle.explicit`), whose "right" rows then hold by
construction. Each value declares the columns of x's block "p", the rows imposed at each
step, and how the step terms, the goal rows and `momenta(x)` read p_k.
"""

import casadi as ca
import numpy as np

from ..._util import checks
from ..._util.cache import BoundedCache
from ..._util.numeric import Evaluator
from ...principle.explicit import single_output, solved_rows, substitutable
from .terms import broadcast, inputs_of

MOMENTA = ("substituted", "variables")

_MOMENTA = BoundedCache(32, "momenta")     # p1 mapped over N steps on stacked inputs, by (residual, N)


def momentum_treatment(momenta, residual):
    """The value of the problem's `momenta` choice for `residual`: SubstitutedMomenta when
    "substituted" is asked for and p_{k+1} is explicit and free of p_k
    (`dmoc.principle.explicit.substitutable`), else CarriedMomenta."""
    if checks.choice("momenta", momenta, MOMENTA) == "substituted" and substitutable(residual):
        return SubstitutedMomenta(residual)
    return CarriedMomenta(residual)


class CarriedMomenta:
    """p_0 ... p_N variables (x's block "p" of N+1 columns), every row of the residual
    imposed at every step.

    Parameters
    ----------
    residual : StepResidual
    """

    name = "variables"

    def __init__(self, residual):
        self.residual = residual
        self.dynamics_rows = residual.row_layout

    def columns(self, steps):
        """Columns of x's block "p": N + 1."""
        return steps + 1

    def dynamics_terms(self, slots, rows):
        """One term: the residual of every step k at (q_k, p_k, q_{k+1}, p_{k+1}, ...) and
        its cost C_d, filling the rows `rows` (index array, a column per step)."""
        R, X, N = self.residual, slots.X, slots.N
        window = {**slots.at(0, N), "p0": ("x", X["p"][:, :N]), "p1": ("x", X["p"][:, 1:])}
        return [slots.term("dynamics", window,
                           lambda s: (slots.step_cost(s), R.function(**inputs_of(R.function, s))["r"]), rows)]

    def goal_slots(self, slots):
        """The goal term's slot of p_N: its variables."""
        return {"p": ("x", slots.X["p"][:, slots.N:])}

    def goal_momentum(self, s):
        """p_N in the goal term's symbols `s`."""
        return s["p"]

    def momenta_function(self, slots):
        """``momenta(x, p) -> P`` (n, N+1): the block "p" of x."""
        index = slots.X["p"]
        return lambda x, p: x[index]

    def __repr__(self):
        return "CarriedMomenta()"


class SubstitutedMomenta:
    """Only p_0 a variable (x's block "p" of one column); step k >= 1 reads the window of
    steps k-1 and k, its p_k the explicit p1 of step k-1; the residual's "right" rows are
    not imposed.

    Parameters
    ----------
    residual : StepResidual
        Whose p_{k+1} is explicit and free of p_k.
    """

    name = "substituted"

    def __init__(self, residual):
        self.residual = residual
        self.dynamics_rows = solved_rows(residual)
        self.p1 = single_output(residual, "p1")
        self.rows = single_output(residual, "rows")

    def columns(self, steps):
        """Columns of x's block "p": 1 (p_0)."""
        return 1

    def dynamics_terms(self, slots, rows):
        """Two terms: step 0 with p_0 from x, steps 1 ... N-1 with p_k from the previous
        step (slots with suffix "_prev"); their rows and costs C_d."""
        X, N = slots.X, slots.N
        first = {**slots.at(0, 1), "p0": ("x", X["p"][:, :1])}
        later = {**slots.at(1, N), **slots.at(0, N - 1, "_prev")}
        return [slots.term("dynamics_0", first, lambda s: (slots.step_cost(s), self._rows(s)), rows[:, :1]),
                slots.term("dynamics", later, lambda s: (slots.step_cost(s), self._rows(
                    {**s, "p0": self.previous_momentum(s)})), rows[:, 1:])]

    def _rows(self, s):
        return self.rows(**inputs_of(self.rows, s))["rows"]

    def previous_momentum(self, s):
        """p_k of the window's previous step (symbols with suffix "_prev")."""
        return self.p1(**{k: s[k if k == "h" else k + "_prev"] for k in self.p1.name_in()})["p1"]

    def goal_slots(self, slots):
        """The goal term reads step N-1, whose explicit p1 is p_N."""
        return slots.at(slots.N - 1, slots.N, "_prev")

    def goal_momentum(self, s):
        """p_N in the goal term's symbols `s`."""
        return self.previous_momentum(s)

    def momenta_function(self, slots):
        """``momenta(x, p) -> P`` (n, N+1): p_0 from x and the explicit p_{k+1} of every
        step: the windows of p1's inputs gathered from x and p, stacked, and p1 mapped over
        the N steps on that one stacked input (a Function kept in a bounded cache per
        residual and N, so that a call passes one array, not one per input of p1). The
        stack is gathered by two index arrays made once (`_gathering`) and evaluated
        through the Function's buffer (`dmoc._util.numeric.Evaluator`: no conversion to
        ``casadi.DM``, which took most of the call). It holds index arrays and p1 only,
        not the problem."""
        X, N, p1, key = slots.X, slots.N, self.p1, (self.residual.key, slots.N)
        windows = [slots.at(0, N, "_prev")[k if k == "h" else k + "_prev"] for k in p1.name_in()]
        gather, shift = _gathering(windows, slots.q_ref, N, slots.n_x, slots.n_p)

        def momenta(x, p):
            values = np.concatenate([x, p, _ZERO])
            mapped = _MOMENTA.get(key, lambda: Evaluator(_stacked(p1).map(N)))
            (following,) = mapped((values[gather] + values[shift]).ravel())    # the stack, (rows, N)
            return np.hstack([x[X["p"][:, :1]], following])
        return momenta

    def __repr__(self):
        return "SubstitutedMomenta()"


_ZERO = np.zeros(1)


def _gathering(windows, q_ref, N, n_x, n_p):
    """(gather, shift): index arrays (N, rows) into ``values = [x; p; 0]`` (x of `n_x`
    entries, p of `n_p`) such that ``values[gather] + values[shift]`` is the transpose of
    the stack (rows, N) of the `windows` ((source, index) of p1's inputs, in order) over the
    N steps (so that, raveled, it is the stack column by column), with q_ref (index (n, 1)
    into p) added to the slots of source "q" and 0.0 to the others: the additions of
    gathering each window on its own, entry by entry."""
    offset, zero = {"x": 0, "q": 0, "p": n_x}, n_x + n_p
    gather, shift = [], []
    for src, index in windows:
        rows = broadcast(index, N)
        gather.append(rows + offset[src])
        shift.append(np.broadcast_to(q_ref + n_x, rows.shape) if src == "q" else np.full(rows.shape, zero))
    return np.vstack(gather).T.copy(), np.vstack(shift).T.copy()


def _stacked(function):
    """`function` of column-vector inputs as a Function of one input, their stack (in
    the order of its inputs), calling it."""
    sizes = [function.numel_in(i) for i in range(function.n_in())]
    z = ca.MX.sym("z", sum(sizes))
    inputs = ca.vertsplit(z, np.cumsum([0] + sizes).tolist())
    return ca.Function(function.name() + "_stacked", [z], [function(*inputs)], ["z"], function.name_out())
