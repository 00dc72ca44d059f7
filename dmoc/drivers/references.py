"""What a receding-horizon controller's problem reads along its horizon at each step (a
driver: the optimizer in a closed loop): the window of a long reference (a planned
trajectory and its feed-forward) that starts at the step, and the clock's start time, as
new values of the problem's parameters (`OptimalControlProblem.with_parameters`: entries of
p, no new NLP).
"""

import numpy as np

from .._util import checks
from ..errors import InputError, InputTypeError
from ..optimal_control.statement.parameter_schedule import CLOCK, FIXED, PER_KNOT


class HorizonReferences:
    """The windows of `references` and the clock that a controller's horizon reads at
    each step.

    Parameters
    ----------
    problem : OptimalControlProblem
        Its parameters given per step (shape (N, k)) or per knot (shape (N+1, k)) may be
        named in `references`.
    references : dict of str -> array_like of shape (M, k), or None
        Each the whole run's values of such a parameter, M >= 1 rows: at controller step j
        the problem reads rows j ... j+N-1 (per step) or j ... j+N (per knot), the last row
        repeated past the end (a reference that ends at rest holds its goal).

    Attributes
    ----------
    values : dict of str -> ndarray, shape (M, k)
    time : ndarray, shape (1,), or None
        With the clock ``"t"`` among the problem's parameters, the start time of the next
        step (`advance` moves it on by the steps applied).
    names : set of str
        The parameters the controller sets: those of `values`, and ``"t"`` with the clock.
    """

    def __init__(self, problem, references):
        if references is None:
            references = {}
        if not isinstance(references, dict):
            raise InputTypeError(f"`references` must be a dict of parameter name -> array of shape "
                                 f"(M, k), or None; got {type(references).__name__}.")
        kinds, N = problem.parameters.schedule.kinds, problem.steps
        self._rows, self.values = {}, {}
        for name, value in references.items():
            if kinds.get(name, FIXED) == FIXED:          # the clock is a fixed value too
                along = sorted(k for k, kind in kinds.items() if kind != FIXED)
                raise InputError(f"`references` names parameters given per step or per knot of "
                                 f"`problem`, {along}; got {name!r}.")
            k = problem.parameter_values[name].shape[1]
            array = checks.real_array(f"references[{name!r}]", value)
            if array.ndim != 2 or array.shape[0] < 1 or array.shape[1] != k or not np.isfinite(array).all():
                raise InputError(f"`references[{name!r}]` must be a finite array of shape (M, {k}), "
                                 f"M >= 1 rows; got shape {array.shape}"
                                 f"{'' if np.isfinite(array).all() else ' with a NaN or infinite entry'}.")
            self.values[name] = array
            self._rows[name] = N + (kinds[name] == PER_KNOT)
        self.time = problem.parameter_values.get(CLOCK)
        self.names = set(self.values) | ({CLOCK} if self.time is not None else set())

    def at(self, step):
        """The parameter values of controller step `step`: the `window`, and the clock's
        start time."""
        out = self.window(step)
        if self.time is not None:
            out[CLOCK] = self.time
        return out

    def advance(self, h):
        """Move the clock on by the step `h` just applied."""
        if self.time is not None:
            self.time = self.time + h

    def window(self, step):
        """{name: rows step ... step + N - 1 (or + N), shape (N, k) or (N+1, k)} at
        controller step `step`, the last row repeated past the end."""
        out = {}
        for name, array in self.values.items():
            rows = np.minimum(np.arange(step, step + self._rows[name]), len(array) - 1)
            out[name] = array[rows]
        return out
