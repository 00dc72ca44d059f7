"""`dmoc.optimal_control.solver.violation.largest_violation`, the CasADi Function that the packed IPOPT
call evaluates at IPOPT's last g and `most_violated` at any g, against its definition
written out row by row in Python: the largest of max(lbg - g, g - ubg) over the rows, a
row whose difference is NaN (g NaN, or g and its bound infinite alike) violated by inf,
the first row that has it, and (0, 0) when no row is violated — also for rows that are
all inequalities, whose violations may all be negative (a DMOC NLP always has equality
rows, whose violation |g| is never negative).
"""

import math

import numpy as np
import pytest

from dmoc._util.numeric import Evaluator
from dmoc.optimal_control.solver.violation import largest_violation


def defined(g, lbg, ubg):
    """(largest violation, first row) by the definition, row by row."""
    values = []
    for gi, lo, up in zip(g, lbg, ubg):
        below, above = lo - gi, gi - up
        values.append(math.inf if math.isnan(below) or math.isnan(above) else max(below, above, 0.0))
    largest = max(values)
    return largest, values.index(largest) if largest > 0 else 0


@pytest.mark.parametrize("kind", ["equalities and inequalities", "inequalities only"])
def test_the_largest_violation_and_its_row_by_their_definition(kind):
    rng = np.random.default_rng(11)
    n = 17
    largest = Evaluator(largest_violation(n))
    for trial in range(400):
        if kind == "inequalities only":
            lbg, ubg = np.full(n, -np.inf), rng.choice([0.0, 1.0, np.inf], size=n)
            g = np.where(np.isfinite(ubg), ubg, 0.0) - np.abs(rng.normal(size=n))      # all met ...
            if trial % 2:
                g[rng.integers(n)] += 3.0 * rng.random()                                 # ... or not
        else:
            lbg = rng.choice([0.0, -np.inf, -1.0], size=n)
            ubg = np.where(lbg == -1.0, 1.0, 0.0)
            g = rng.normal(size=n) * rng.choice([0.0, 1e-3], size=n)
        specials = rng.choice([np.nan, np.inf, -np.inf], size=(trial % 3) * (trial % 4 == 0))
        g[rng.choice(n, size=specials.size, replace=False)] = specials
        if trial % 7 == 0:
            g[rng.integers(n)] = g[rng.integers(n)]         # ties: the first row of the largest
        with np.errstate(invalid="ignore"):
            value, row = largest(g, lbg, ubg)
            expected = defined(g, lbg, ubg)
        assert (value[0, 0], int(row[0, 0])) == expected, (g, lbg, ubg)


def test_no_row_violated_gives_zero_and_row_zero():
    largest = Evaluator(largest_violation(3))
    value, row = largest([-2.0, -1.0, -3.0], [-np.inf] * 3, [0.0] * 3)
    assert (value[0, 0], row[0, 0]) == (0.0, 0.0)
