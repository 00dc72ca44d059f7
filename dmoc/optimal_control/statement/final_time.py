"""The final time of a DMOC problem, chosen once as a value (consumer 2 of the step
residual): fixed, T = N h with the discretization's step h an entry of the NLP's parameter
vector p, or free in [T_min, T_max], h = T / N an entry of x. The transcription, the guess
and the result read where h lives and what range it has from this value instead of
testing a flag; `as_final_time` makes it from a problem's `duration` argument.
"""

import numpy as np

from ..._util import checks
from ...errors import InputError


class FixedFinalTime:
    """T = N h with h the discretization's step: h is the block "h" of p.

    Parameters
    ----------
    h : float
        The step.

    Examples
    --------
    >>> fixed = FixedFinalTime(0.1)
    >>> fixed.free, fixed.x_entries, fixed.p_values.tolist(), fixed.step_range(10)
    (False, 0, [0.1], (0.1, 0.1))
    """

    free = False
    x_entries = 0          # entries of x's block "h"
    duration = None

    def __init__(self, h):
        self.h = float(h)

    @property
    def p_values(self):
        """The values of p's block "h", shape (1,)."""
        return np.array([self.h])

    def slot(self, X, P):
        """Where a step term reads h: ("p", indices of p's block "h"), from the index
        arrays X of x and P of p by block."""
        return "p", P["h"]

    def step_range(self, steps):
        """(h_min, h_max) of the step over `steps` steps: (h, h)."""
        return self.h, self.h

    def step(self, x_layout, x):
        """The step of an NLP vector x: h."""
        return self.h

    def __repr__(self):
        return f"FixedFinalTime(h={self.h:g})"


class FreeFinalTime:
    """T in [T_min, T_max] a decision variable: h = T / N is the block "h" of x.

    Parameters
    ----------
    T_min, T_max : float
        0 < T_min <= T_max.

    Examples
    --------
    >>> free = FreeFinalTime(1.0, 2.0)
    >>> free.free, free.x_entries, free.p_values.size, free.step_range(10)
    (True, 1, 0, (0.1, 0.2))
    """

    free = True
    x_entries = 1

    def __init__(self, T_min, T_max):
        self.duration = (float(T_min), float(T_max))

    @property
    def p_values(self):
        """The values of p's block "h": none, shape (0,)."""
        return np.zeros(0)

    def slot(self, X, P):
        """Where a step term reads h: ("x", indices of x's block "h")."""
        return "x", X["h"]

    def step_range(self, steps):
        """(T_min / steps, T_max / steps): the bounds of h."""
        return tuple(T / steps for T in self.duration)

    def step(self, x_layout, x):
        """The step h held in the NLP vector x."""
        return float(x_layout.unpack(x, "h")[0, 0])

    def __repr__(self):
        return f"FreeFinalTime(T_min={self.duration[0]:g}, T_max={self.duration[1]:g})"


def as_final_time(duration, N, h):
    """The FixedFinalTime (duration None) or FreeFinalTime of the `duration` argument."""
    if duration is None:
        return FixedFinalTime(h)
    if not isinstance(duration, (tuple, list)) or len(duration) != 2:
        raise InputError(f"`duration` must be None (fixed, steps * h = {N * h:g}) or a pair "
                         f"(T_min, T_max) for a free final time; got {duration!r}.")
    T_min, T_max = (checks.positive_float("duration", T) for T in duration)
    if T_min > T_max:
        raise InputError(f"`duration` must have T_min <= T_max; got {duration!r}.")
    return FreeFinalTime(T_min, T_max)
