"""Boundary data shared by both consumers (docs/theory.md, "Conventions"):
p_0 = dL/dv(q_0, v_0) at the start, and p_N - dL/dv(q_N, v_N) in Delta°_Q(q_N) at the end,
with the impulses where the formulation puts them (on every constraint one-form, dg/dq of
the holonomic constraints included), and the checks of given data: g(q) = 0 for
configurations, A(q) v = 0 for velocities (for holonomic constraints the hidden constraint
dg/dq(q) v = 0).
"""

import casadi as ca
import numpy as np

from . import _checks


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
        raise ValueError("give exactly one of `v0` (initial velocity) and `p0` (initial momentum).")
    n = system.n
    check_configuration("q0", system, q0)
    if p0 is not None:
        return _checks.array("p0", p0, (n,)), np.zeros(n)
    if not hasattr(system, "lagrangian"):
        raise ValueError("give `p0` (initial momentum) for a HamiltonianSystem: `v0` would need "
                         "the inverse of v = dH/dp(q, p), which dmoc does not form.")
    v0 = _checks.array("v0", v0, (n,))
    check_allowed_velocity("v0", system, q0, v0)
    return np.array(system.momentum(q0, v0)).ravel(), v0


def check_allowed_velocity(name, system, q, v):
    """Raise ValueError naming `name` unless A(q) v = 0 (v in Delta_Q(q)); the rows of A
    include dg/dq, so a holonomic system's v must satisfy the hidden constraint."""
    if system.m == 0:
        return
    violation = np.array(system.constraint_matrix(q) @ v).ravel()
    size = float(np.max(np.abs(violation)))
    if size > constraint_violation_tolerance(float(np.max(np.abs(v)))):
        hidden = (" and the hidden constraints dg/dq(q) v = 0 of `holonomic` (v tangent to "
                  "g(q) = 0)") if system.n_holonomic else ""
        raise ValueError(
            f"`{name}` violates the velocity constraints: |A(q) {name}| = {size:.3e}; "
            f"allowed velocities are ker A(q) (the rows of A are the constraint one-forms"
            f"{hidden}).")


def check_configuration(name, system, q):
    """Raise ValueError naming `name` unless g(q) = 0 within 1e-9 of the change of g that a
    relative rounding of q makes (abs(q) times abs(dg/dq), at least 1)."""
    if system.n_holonomic == 0:
        return
    violation = float(np.max(np.abs(np.array(system.holonomic(q)))))
    jacobian = np.array(system.constraint_matrix(q))[system.m - system.n_holonomic:]
    scale = float(np.max(np.abs(q))) * float(np.max(np.abs(jacobian)))
    if violation > constraint_violation_tolerance(scale):
        raise ValueError(
            f"`{name}` violates the holonomic constraints: max abs(g({name})) = {violation:.3e}; "
            f"give a configuration on g(q) = 0.")


def momentum_condition(system, label, multiplier, sign):
    """The momentum boundary row ``label(q, p, v, multiplier) -> r`` (shape (n,)) and the
    multiplier's size (m, or 0 when `sign` is 0): r = 0 says that p + sign A(q)^T
    multiplier is the momentum of v at q (`system.momentum_residual`: p - dL/dv(q, v) for a
    MechanicalSystem, dH/dp(q, p) - v for a HamiltonianSystem).

    The formulations (`dmoc.formulations`) say which end carries an impulse and with which
    sign: (+) p_N = dL/dv(q_N, v_N) + A(q_N)^T nu, (-) p_0 = dL/dv(q_0, v_0) - A(q_0)^T mu,
    A(q) holding every constraint one-form (the holonomic ones' dg/dq included).
    """
    n, size = system.n, system.m if sign else 0
    q, p, v, mult = ca.SX.sym("q", n), ca.SX.sym("p", n), ca.SX.sym("v", n), ca.SX.sym(multiplier, size)
    impulse = sign * ca.mtimes(system.constraint_matrix(q).T, mult) if sign else 0
    r = system.momentum_residual(q, p + impulse, v)
    return ca.Function(label, [q, p, v, mult], [r], ["q", "p", "v", multiplier], ["r"]), size


def check_holonomic_boundary(system, q_start, q_goal):
    """Raise ValueError before an optimal control problem is solved if its boundary
    configurations do not fit the holonomic constraints g(q) = 0 of `system`.

    Parameters
    ----------
    system : MechanicalSystem
    q_start, q_goal : ndarray, shape (n,)
        Boundary configurations, NaN entries free.

    Raises
    ------
    ValueError
        `q_start` with free entries (the step rows impose g(q_{k+1}) = 0, k = 0 ... N-1, so
        nothing would impose g(q_0) = 0); a fully given `q_start` or `q_goal` off g = 0; or
        a `q_goal` that over-determines g: the step rows already impose g(q_N) = 0, so at
        most n - k entries can be given. The message names the entries to leave free (None):
        those whose columns of dg/dq(q_goal) are best conditioned (QR with column pivoting).

    Notes
    -----
    A fully given goal on g = 0 satisfies g(q_N) = 0 redundantly: the NLP's constraint
    Jacobian is rank-deficient there and IPOPT may report success at a point that is not
    the optimum. With those entries free the goal is the same set, stated once.
    """
    k, n = system.n_holonomic, system.n
    if k == 0:
        return
    if not np.isfinite(q_start).all():
        raise ValueError(
            "`q_start` must be fully given for a system with holonomic constraints: the step "
            "rows impose g(q_{k+1}) = 0, so free start entries would leave g(q_0) = 0 unimposed.")
    check_configuration("q_start", system, q_start)
    given = np.flatnonzero(np.isfinite(q_goal))
    if len(given) == n:
        check_configuration("q_goal", system, q_goal)
    if len(given) <= n - k:
        return
    jacobian = np.array(system.constraint_matrix(np.nan_to_num(q_goal)))[system.m - k:]
    free = sorted(int(i) for i in given[_pivot_columns(jacobian[:, given], len(given) - (n - k))])
    raise ValueError(
        f"`q_goal` over-determines the holonomic constraints: the step rows impose the k = {k} "
        f"equations g(q_N) = 0, so at most n - k = {n - k} of its entries can be given; it gives "
        f"{len(given)}. Leave entries {free} {tuple(system.names[i] for i in free)} free "
        f"(None): the goal set is the same, and the NLP stays regular.")


def _pivot_columns(matrix, count):
    """Indices of `count` columns of `matrix` chosen as QR with column pivoting chooses
    them: each the column of largest norm after removing the span of those chosen."""
    rest, chosen = np.array(matrix, dtype=float), []
    for _ in range(count):
        j = int(np.argmax(np.linalg.norm(rest, axis=0)))
        chosen.append(j)
        e = rest[:, j] / np.linalg.norm(rest[:, j])
        rest = rest - np.outer(e, e @ rest)
    return np.array(chosen, dtype=int)
