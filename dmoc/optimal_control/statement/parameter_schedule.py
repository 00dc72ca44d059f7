"""Where the values of a DMOC problem's parameters sit along the horizon (the statement of
consumer 2): a parameter is fixed (one value, shape (k,)), given per step (shape (N, k),
row k held on [t_k, t_{k+1}] as the controls are) or per knot (shape (N+1, k), row k at t_k,
linear in time between knots), and the clock ``"t"`` is the time t = t_0 + (k + c) h at the
fraction c of step k. The user's callables read one value of each (the "point" vector w);
the NLP stores them all in p, and each step's terms read the "step" vector of their step,
from which the point vector at any fraction c of the step follows (`ParameterSchedule.at`).
"""

import casadi as ca
import numpy as np

from ..._util.layout import Layout

FIXED, PER_STEP, PER_KNOT = "fixed", "per step", "per knot"
CLOCK = "t"


class ParameterSchedule:
    """The kinds of a problem's parameters and their places in p.

    Parameters
    ----------
    values : dict of str -> ndarray
        Shapes (k,) (fixed), (N, k) (per step) or (N+1, k) (per knot); ``"t"``, when
        given, is the clock, a scalar: the start time t_0.
    steps : int
        N.

    Attributes
    ----------
    kinds : dict of str -> str
        "fixed", "per step" or "per knot" by name.
    layout : Layout
        The point vector w the user's callables read: one block of k entries per name,
        the value at the point (``"t"`` the time there).
    varying : bool
        Whether some value changes along the horizon (a parameter per step or per knot, or
        the clock). When not, the step vector is the point vector itself.
    size : int
        Entries of the stored vector (`stored`): the values raveled row by row, then,
        with the clock, the knot indices 0 ... N.
    step_size : int
        Entries of the step vector: without `varying`, ``layout.size``; with it, the
        point vector at the step's start (a), at its end (b) and t_0: 2 ``layout.size``
        + 1 with the clock (a and b hold the knot indices k and k + 1 in the clock's
        entry).
    key : tuple
        The kinds and sizes by name: what the terms' Functions depend on besides the
        user's Functions.
    """

    def __init__(self, values, steps):
        self.steps = steps
        self.kinds = {name: _kind(v, steps) for name, v in values.items()}
        self.layout = Layout([(name, v.shape[-1]) for name, v in values.items()])
        self.varying = CLOCK in values or any(k != FIXED for k in self.kinds.values())
        self._offsets = dict(zip(values, np.cumsum([0] + [v.size for v in values.values()])))
        stored = sum(v.size for v in values.values())
        self._clock = stored if CLOCK in values else None
        self.size = stored + (steps + 1 if CLOCK in values else 0)
        P = self.layout.size
        self.step_size = 2 * P + (CLOCK in values) if self.varying else P
        self.key = tuple((name, self.kinds[name], v.shape[-1]) for name, v in values.items())
        self._point_function = None

    def stored(self, values):
        """The vector p holds, shape (size,), of `values` (same names and shapes)."""
        parts = [v.ravel() for v in values.values()]
        if self._clock is not None:
            parts.append(np.arange(self.steps + 1, dtype=float))
        return np.concatenate(parts or [np.zeros(0)])

    def step_indices(self):
        """Indices into `stored`, shape (step_size, N), the step vector of step k in column
        k; shape (size, 1), shared by every step, without `varying`."""
        if not self.varying:
            return np.arange(self.size)[:, None]
        k = np.arange(self.steps)
        return np.vstack([self._point(k, k), self._point(k, k + 1), self._start_time(k)])

    def knot_indices(self):
        """Indices into `stored`, shape (step_size, N+1): column k a step vector whose
        point at every fraction c is the value at knot k (a = b: per-step values of the
        step that starts there, the last step's at q_N; the clock t_k)."""
        if not self.varying:
            return np.broadcast_to(np.arange(self.size)[:, None], (self.size, self.steps + 1))
        k = np.arange(self.steps + 1)
        point = self._point(np.minimum(k, self.steps - 1), k)
        return np.vstack([point, point, self._start_time(k)])

    def at(self, w, c, h):
        """The point vector (CasADi column of layout.size) at the fraction `c` of a step
        of length `h` whose step vector is `w`: a + c (b - a) (per-knot values linear in
        time; the others a = b), the clock's entry t_0 + (k + c) h. Without `varying`, `w`
        itself."""
        if not self.varying:
            return w
        P = self.layout.size
        a, b = w[:P], w[P:2 * P]
        point = a + c * (b - a)
        if self._clock is not None:
            i = self.layout.slice(CLOCK).start
            point[i] = w[2 * P] + point[i] * h
        return point

    def _point(self, step_rows, knot_rows):
        """Indices (layout.size, len) of the point values with per-step rows `step_rows`
        and per-knot rows `knot_rows` (the clock's entry: the knot index stored at
        `knot_rows`)."""
        blocks = []
        for name, kind in self.kinds.items():
            offset, size = self._offsets[name], self.layout.numel(name)
            if name == CLOCK:
                blocks.append(self._clock + knot_rows[None, :])
                continue
            row = {FIXED: 0 * knot_rows, PER_STEP: step_rows, PER_KNOT: knot_rows}[kind]
            blocks.append(offset + size * row[None, :] + np.arange(size)[:, None])
        return np.vstack(blocks) if blocks else np.zeros((0, len(knot_rows)), int)

    def _start_time(self, columns):
        """The index of t_0 repeated over `columns` (no row without the clock)."""
        if self._clock is None:
            return np.zeros((0, len(columns)), int)
        return np.full((1, len(columns)), self._offsets[CLOCK])

    def point_function(self):
        """``(w, c, h) -> point`` of `at` as a casadi.Function (for the rule's quadrature
        of the running cost, `Discretization.discrete_cost`), or None without `varying`;
        built once per schedule (the problems of one NLP share it)."""
        if not self.varying:
            return None
        if self._point_function is None:
            w, c, h = ca.SX.sym("w", self.step_size), ca.SX.sym("c"), ca.SX.sym("h")
            self._point_function = ca.Function("parameters_at", [w, c, h], [self.at(w, c, h)],
                                               ["w", "c", "h"], ["w_c"])
        return self._point_function


def _kind(value, steps):
    """FIXED for shape (k,), PER_STEP for (N, k), PER_KNOT for (N+1, k) (checked before)."""
    if value.ndim == 1:
        return FIXED
    return PER_STEP if value.shape[0] == steps else PER_KNOT
