"""Momentum boundary data shared by both consumers (THEORY.md, "Optimal control"):
p_0 = dL/dv(q_0, v_0) at the start, and p_N - dL/dv(q_N, v_N) in Delta°_Q(q_N) at the end.
"""

import casadi as ca
import numpy as np

from . import _checks


def constraint_violation_tolerance(scale):
    """Tolerance for A(q) v = 0 on user data: 1e-9 relative to the data's size."""
    return 1e-9 * max(1.0, scale)


def start_momentum(system, q0, v0, p0):
    """Initial momentum from exactly one of `v0` (then p_0 = dL/dv(q0, v0)) or `p0`.

    Returns
    -------
    p_start : ndarray, shape (n,)
    v_guess : ndarray, shape (n,)
        `v0`, or zeros when `p0` is given (a Newton warm start only).

    Raises
    ------
    ValueError
        Both or neither of v0/p0 given, wrong shapes, non-finite values, or v0 outside
        Delta_Q(q0) = ker A(q0).
    """
    if (v0 is None) == (p0 is None):
        raise ValueError("give exactly one of `v0` (initial velocity) and `p0` (initial momentum).")
    n = system.n
    if p0 is not None:
        return _checks.array("p0", p0, (n,)), np.zeros(n)
    v0 = _checks.array("v0", v0, (n,))
    check_allowed_velocity("v0", system, q0, v0)
    return np.array(system.momentum(q0, v0)).ravel(), v0


def check_allowed_velocity(name, system, q, v):
    """Raise ValueError naming `name` unless A(q) v = 0 (v in Delta_Q(q))."""
    if system.m == 0:
        return
    violation = np.array(system.constraint_matrix(q) @ v).ravel()
    size = float(np.max(np.abs(violation)))
    if size > constraint_violation_tolerance(float(np.max(np.abs(v)))):
        raise ValueError(
            f"`{name}` violates the velocity constraints: |A(q) {name}| = {size:.3e}; "
            f"allowed velocities are ker A(q) (the rows of A are the constraint one-forms).")


def momentum_conditions(system, variant):
    """Symbolic momentum boundary conditions of the (+)/(-) principle, for the optimizer.

    Returns
    -------
    start, end : casadi.Function
        ``start(q, p, v, mu) -> r`` and ``end(q, p, v, nu) -> r``, r of shape (n,).
    m_start, m_end : int
        Sizes of the impulse multipliers mu and nu (m or 0).

    Notes
    -----
    (+): p_0 = dL/dv(q_0, v_0) and p_N = dL/dv(q_N, v_N) + A(q_N)^T nu: lam_k of (37) sits
    at q_k, so the impulse at q_N is a boundary unknown.
    (-): p_0 = dL/dv(q_0, v_0) - A(q_0)^T mu and p_N = dL/dv(q_N, v_N): lam_k of (41) sits
    at q_{k+1}, so lam_{N-1} is the impulse at q_N and the start needs one (the initial
    impulse of THEORY.md, as in `simulate`).
    """
    n, m = system.n, system.m
    q, p, v, mult = ca.SX.sym("q", n), ca.SX.sym("p", n), ca.SX.sym("v", n), ca.SX.sym("mult", m)
    impulse = ca.mtimes(system.constraint_matrix(q).T, mult)
    free = p - system.momentum(q, v)
    zero = ca.SX.sym("none", 0)
    if variant == "+":
        start = ca.Function("start_momentum", [q, p, v, zero], [free], ["q", "p", "v", "mu"], ["r"])
        end = ca.Function("end_momentum", [q, p, v, mult], [free - impulse], ["q", "p", "v", "nu"], ["r"])
        return start, end, 0, m
    start = ca.Function("start_momentum", [q, p, v, mult], [free + impulse], ["q", "p", "v", "mu"], ["r"])
    end = ca.Function("end_momentum", [q, p, v, zero], [free], ["q", "p", "v", "nu"], ["r"])
    return start, end, m, 0
