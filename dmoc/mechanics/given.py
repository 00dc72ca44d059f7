"""The mechanics stage's checks of given data: g(q) = 0 for configurations, A(q) v = 0 for
velocities (for holonomic constraints the hidden constraint dg/dq(q) v = 0), and the initial
momentum p_0 = dL/dv(q_0, v_0) of given start data (docs/theory.md, "Conventions").
"""

import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from .._util.numeric import Evaluator
from ..errors import InputError

# (kind of system, its key, Function name, runs) -> Evaluator: the checks below run on
# every `simulate` call, where an ordinary CasADi call costs 30 us and an Evaluator 8 us
_EVALUATORS = BoundedCache(64, "numeric system functions")
MAPPED = 64       # most runs per call of a system Function mapped over runs (`numeric_rows`)


def numeric(system, name, runs=1):
    """`system`'s CasADi Function `name` (``"momentum"``, ``"constraint_matrix"``, ...) as
    an `Evaluator`, built once for systems of equal data (`key`); for `runs` > 1 its
    serial map over that many runs (CasADi's map calls the Function itself for each run,
    so each run's outputs have the bits of one call)."""
    def build():
        function = getattr(system, name)
        if runs > 1:
            function = function.map(f"{name}_x{runs}", "serial", runs, [], [])
        return Evaluator(function)
    return _EVALUATORS.get((type(system).__name__, system.key, name, runs), build)


def numeric_rows(system, name, *rows):
    """`system`'s Function `name` at R runs, one call per block of runs (powers of two up
    to MAPPED, `numeric`): `rows` hold the inputs, one array (R, entries) each; per
    output an array (rows, cols, R) in column-major order, whose ``[:, :, j]`` is run j's
    output as ``numeric(system, name)`` gives it: the same bits, in the same memory
    order (column-major)."""
    R, first, outputs = rows[0].shape[0], 0, None
    while first < R:
        width = min(MAPPED, 1 << ((R - first).bit_length() - 1))
        values = numeric(system, name, width)(*(a[first:first + width].ravel() for a in rows))
        if outputs is None:
            outputs = [np.empty((v.shape[0], v.shape[1] // width, R), order="F") for v in values]
        for whole, v in zip(outputs, values):
            whole[:, :, first:first + width] = v.reshape(whole.shape[:2] + (width,), order="F")
        first += width
    return outputs


def constraint_violation_tolerance(scale):
    """Tolerance for A(q) v = 0 on user data: 1e-9 relative to the data's size."""
    return 1e-9 * max(1.0, scale)


def given_start(system, q0, v0, p0, checked=()):
    """The start data of a run checked as far as it can be alone: exactly one of `v0`
    (initial velocity; a MechanicalSystem only) or `p0` (initial momentum); those of
    them named in `checked` are float arrays of shape (n,) that `checks.array` passed
    already.

    Returns
    -------
    v0, p0 : ndarray, shape (n,), or None
        The one given, checked; the other None. A `v0` still has to lie in
        Delta_Q(q0) and gives p_0 = dL/dv(q0, v0) (`start_momenta`).

    Raises
    ------
    ValueError
        Both or neither of v0/p0 given, wrong shapes, non-finite values, or q0 off the
        holonomic constraints g(q0) = 0.
    """
    if (v0 is None) == (p0 is None):
        raise InputError("give exactly one of `v0` (initial velocity) and `p0` (initial momentum).")
    n = system.n
    check_configuration("q0", system, q0)
    if p0 is not None:
        return None, p0 if "p0" in checked else checks.array("p0", p0, (n,))
    if not hasattr(system, "lagrangian"):
        raise InputError("give `p0` (initial momentum) for a HamiltonianSystem: `v0` would need "
                         "the inverse of v = dH/dp(q, p), which dmoc does not form.")
    return v0 if "v0" in checked else checks.array("v0", v0, (n,)), None


def start_momenta(system, q0, v0):
    """p_0 = dL/dv(q0, v0) of R runs at once (`numeric_rows`: the bits of one run's call),
    q0 and v0 of shape (R, n) from `given_start`.

    Returns
    -------
    p : ndarray, shape (R, n)
    errors : list of length R
        None, or the InputError `check_allowed_velocity` raises for that run's `v0`.
    """
    return numeric_rows(system, "momentum", q0, v0)[0][:, 0, :].T, velocity_errors("v0", system, q0, v0)


def velocity_errors(name, system, q, v):
    """For each of R pairs, rows of `q` and `v` (R, n): None when A(q) v = 0 (v in
    Delta_Q(q)), else the InputError naming `name`; the rows of A include dg/dq, so a
    holonomic system's v must satisfy the hidden constraint. A(q) of all pairs in one
    call per block (`numeric_rows`), each A(q) v as one run's."""
    if system.m == 0:
        return [None] * len(q)
    A = numeric_rows(system, "constraint_matrix", q)[0]
    sizes = np.abs(np.array([A[:, :, j] @ v[j] for j in range(len(v))])).max(axis=1)
    scales = np.abs(v).max(axis=1)
    return [_violation(name, system, float(size))
            if size > constraint_violation_tolerance(float(scale)) else None
            for size, scale in zip(sizes, scales)]


def check_allowed_velocity(name, system, q, v):
    """Raise ValueError naming `name` unless A(q) v = 0 (`velocity_errors` of one pair). A
    zero v (signed zeros included) lies in every Delta_Q: A(q) is not evaluated, as its
    products with v would give |A(q) v| = 0, or NaN where A(q) is not finite, neither
    above the tolerance (a re-solve's goal at rest, benchmarks/peers.py)."""
    if not np.any(v):
        return
    rows = (np.asarray(x, dtype=float).reshape(1, -1) for x in (q, v))
    error = velocity_errors(name, system, *rows)[0]
    if error is not None:
        raise error


def _violation(name, system, size):
    hidden = (" and the hidden constraints dg/dq(q) v = 0 of `holonomic` (v tangent to "
              "g(q) = 0)") if system.n_holonomic else ""
    return InputError(
        f"`{name}` violates the velocity constraints: |A(q) {name}| = {size:.3e}; "
        f"allowed velocities are ker A(q) (the rows of A are the constraint one-forms"
        f"{hidden}).")


def holonomic_residual(system, q):
    """(g(q), shape (k,); whether max abs(g(q)) exceeds 1e-9 of the change of g that a
    relative rounding of q makes, abs(q) times abs(dg/dq), at least 1) for a system with
    holonomic constraints (k > 0)."""
    g = numeric(system, "holonomic")(q)[0].ravel()
    jacobian = numeric(system, "constraint_matrix")(q)[0][system.m - system.n_holonomic:]
    scale = float(np.max(np.abs(q))) * float(np.max(np.abs(jacobian)))
    return g, float(np.max(np.abs(g))) > constraint_violation_tolerance(scale)


def check_configuration(name, system, q):
    """Raise ValueError naming `name` unless g(q) = 0 within 1e-9 of the change of g that a
    relative rounding of q makes (abs(q) times abs(dg/dq), at least 1)."""
    if system.n_holonomic == 0:
        return
    g, off = holonomic_residual(system, q)
    if off:
        violation = float(np.max(np.abs(g)))
        raise InputError(
            f"`{name}` violates the holonomic constraints: max abs(g({name})) = {violation:.3e}; "
            f"give a configuration on g(q) = 0.")
