"""The mechanics stage's checks of given data: g(q) = 0 for configurations, A(q) v = 0 for
velocities (for holonomic constraints the hidden constraint dg/dq(q) v = 0), and the initial
momentum p_0 = dL/dv(q_0, v_0) of given start data (docs/theory.md, "Conventions").
"""

import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from .._util.numeric import Evaluator
from ..errors import InputError

# (kind of system, its key, Function name) -> Evaluator: the checks below run on every
# `simulate` call, where an ordinary CasADi call costs 30 us and an Evaluator 8 us
_EVALUATORS = BoundedCache(32, "numeric system functions")


def numeric(system, name):
    """`system`'s CasADi Function `name` (``"momentum"``, ``"constraint_matrix"``, ...) as
    an `Evaluator`, built once for systems of equal data (`key`)."""
    return _EVALUATORS.get((type(system).__name__, system.key, name),
                           lambda: Evaluator(getattr(system, name)))


def constraint_violation_tolerance(scale):
    """Tolerance for A(q) v = 0 on user data: 1e-9 relative to the data's size."""
    return 1e-9 * max(1.0, scale)


def start_momentum(system, q0, v0, p0):
    """Initial momentum from exactly one of `v0` (then p_0 = dL/dv(q0, v0); a
    MechanicalSystem only) or `p0`.

    Returns
    -------
    p_start : ndarray, shape (n,)
    v_guess : ndarray, shape (n,)
        `v0`, or zeros when `p0` is given (a Newton warm start only).

    Raises
    ------
    ValueError
        Both or neither of v0/p0 given, wrong shapes, non-finite values, q0 off the
        holonomic constraints g(q0) = 0, or v0 outside Delta_Q(q0) = ker A(q0).
    """
    if (v0 is None) == (p0 is None):
        raise InputError("give exactly one of `v0` (initial velocity) and `p0` (initial momentum).")
    n = system.n
    check_configuration("q0", system, q0)
    if p0 is not None:
        return checks.array("p0", p0, (n,)), np.zeros(n)
    if not hasattr(system, "lagrangian"):
        raise InputError("give `p0` (initial momentum) for a HamiltonianSystem: `v0` would need "
                         "the inverse of v = dH/dp(q, p), which dmoc does not form.")
    v0 = checks.array("v0", v0, (n,))
    check_allowed_velocity("v0", system, q0, v0)
    return numeric(system, "momentum")(q0, v0)[0].ravel(), v0


def check_allowed_velocity(name, system, q, v):
    """Raise ValueError naming `name` unless A(q) v = 0 (v in Delta_Q(q)); the rows of A
    include dg/dq, so a holonomic system's v must satisfy the hidden constraint."""
    if system.m == 0:
        return
    violation = numeric(system, "constraint_matrix")(q)[0] @ v
    size = float(np.max(np.abs(violation)))
    if size > constraint_violation_tolerance(float(np.max(np.abs(v)))):
        hidden = (" and the hidden constraints dg/dq(q) v = 0 of `holonomic` (v tangent to "
                  "g(q) = 0)") if system.n_holonomic else ""
        raise InputError(
            f"`{name}` violates the velocity constraints: |A(q) {name}| = {size:.3e}; "
            f"allowed velocities are ker A(q) (the rows of A are the constraint one-forms"
            f"{hidden}).")


def check_configuration(name, system, q):
    """Raise ValueError naming `name` unless g(q) = 0 within 1e-9 of the change of g that a
    relative rounding of q makes (abs(q) times abs(dg/dq), at least 1)."""
    if system.n_holonomic == 0:
        return
    violation = float(np.max(np.abs(numeric(system, "holonomic")(q)[0])))
    jacobian = numeric(system, "constraint_matrix")(q)[0][system.m - system.n_holonomic:]
    scale = float(np.max(np.abs(q))) * float(np.max(np.abs(jacobian)))
    if violation > constraint_violation_tolerance(scale):
        raise InputError(
            f"`{name}` violates the holonomic constraints: max abs(g({name})) = {violation:.3e}; "
            f"give a configuration on g(q) = 0.")
