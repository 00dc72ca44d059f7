"""An LC circuit, a first-stage example system with a degenerate Lagrangian: an inductor in
series with a voltage source feeding two capacitors in parallel. The capacitor charges have
no kinetic energy, Kirchhoff's current law is the constraint one-form (27) and the
capacitor voltages come out equal (Kirchhoff's voltage law) as the multiplier's equations;
its exact solution is an oracle for the discrete principles (46)/(47) (docs/degenerate.md).
"""

import casadi as ca
import numpy as np

from ..._util import checks
from ..given import constraint_violation_tolerance
from ..system import MechanicalSystem
from .knife_edge_model import _check_velocity, _times
from ...errors import InputError


def lc_circuit(inductance=1.0, capacitances=(1.0, 1.0)):
    """LC circuit with two capacitors in parallel, as a MechanicalSystem (n=3, m=1, n_u=1).

    Parameters
    ----------
    inductance : float
        Inductance L_0 > 0.
    capacitances : pair of float
        Capacitances (C_1, C_2), both > 0.

    Returns
    -------
    MechanicalSystem
        q = (q_L, q_1, q_2), shape (3,): the charges through the inductor and the two
        capacitors; one control u, shape (1,): the voltage of a source in series with the
        inductor, named "voltage". Its `units` (for plots): C; V; time in s.

    Notes
    -----
    An implicit Lagrangian system (10) in the sense of [1]_, as LC circuits are in [1]_, [2]_:

        L(q, v) = L_0/2 v_L^2 - q_1^2/(2 C_1) - q_2^2/(2 C_2),
        A(q) = [1, -1, -1]       (Kirchhoff's current law v_L = v_1 + v_2),
        f(q, v, u) = (u, 0, 0).

    L is degenerate: p = dL/dv = (L_0 v_L, 0, 0) for every v, so the Legendre transform is
    not invertible. The Lagrange-d'Alembert equations dp/dt - dL/dq = f + A^T lam read

        L_0 dv_L/dt = u + lam,    q_1/C_1 = -lam,    q_2/C_2 = -lam,

    so both capacitors carry the voltage V = -lam (Kirchhoff's voltage law) and, with
    C = C_1 + C_2 and v_L = C dV/dt, L_0 C d^2V/dt^2 = u - V: an oscillator of frequency
    omega = 1/sqrt(L_0 C).

    References
    ----------
    .. [1] H. Yoshimura and J. E. Marsden, Dirac structures in Lagrangian mechanics
       Part I, J. Geom. Phys. 57 (2006).
    .. [2] A. M. Bloch and P. E. Crouch, Representations of Dirac structures on vector
       spaces and nonlinear L-C circuits, in Differential Geometry and Control Theory,
       AMS, 1997, pp. 103-117.

    Examples
    --------
    >>> s = lc_circuit(2.0, (0.5, 1.5))
    >>> (s.n, s.m, s.n_u, s.names)
    (3, 1, 1, ('q_L', 'q_1', 'q_2'))
    """
    L0 = checks.positive_float("inductance", inductance)
    C1, C2 = _capacitances(capacitances)

    def lagrangian(q, v):
        return L0 / 2 * v[0] ** 2 - q[1] ** 2 / (2 * C1) - q[2] ** 2 / (2 * C2)

    def constraints(q):
        return ca.horzcat(1, -1, -1)

    def force(q, v, u):
        return ca.vertcat(u[0], 0, 0)

    return MechanicalSystem(lagrangian, 3, constraints=constraints, force=force, n_u=1,
                            names=("q_L", "q_1", "q_2"), control_names=("voltage",),
                            units={"t": "s", "q": ("C", "C", "C"), "u": ("V",)})


def lc_circuit_solution(t, q0, v0, *, inductance=1.0, capacitances=(1.0, 1.0)):
    """Exact solution of the unforced LC circuit of :func:`lc_circuit`.

    Parameters
    ----------
    t : float or array_like, shape (N,)
        Times (t = 0 is the initial time).
    q0 : array_like, shape (3,)
        Initial charges (q_L, q_1, q_2); the capacitor voltages must agree,
        q_1/C_1 = q_2/C_2 (Kirchhoff's voltage law).
    v0 : array_like, shape (3,)
        Initial currents; they must satisfy Kirchhoff's current law v_L = v_1 + v_2. Only
        the inductor current v_L is initial data (p_0 = (L_0 v_L, 0, 0)); the capacitor
        currents follow as C_j v_L / C.
    inductance, capacitances : as in :func:`lc_circuit`.

    Returns
    -------
    q, v : ndarray, shape (N, 3)
        Charges and currents at the times `t` (N = 1 for scalar `t`).

    Notes
    -----
    With C = C_1 + C_2, omega = 1/sqrt(L_0 C), V_0 = q_1(0)/C_1 and i_0 = v_L(0):

        V(t) = V_0 cos(omega t) + i_0/(C omega) sin(omega t),
        q_L(t) = q_L(0) + C (V(t) - V_0),   q_j(t) = C_j V(t),
        v_L(t) = C dV/dt = i_0 cos(omega t) - C omega V_0 sin(omega t),   v_j = C_j v_L / C.

    The energy L_0/2 v_L^2 + q_1^2/(2 C_1) + q_2^2/(2 C_2) = (L_0 i^2 + C V^2)/2 is
    conserved.

    Examples
    --------
    >>> q, v = lc_circuit_solution(np.pi / 2, [0, 0.5, 0.5], [0, 0, 0], inductance=0.5)
    >>> # omega = 1: a quarter period, the capacitors discharged through the inductor
    >>> np.round(q, 12) + 0.0
    array([[-1.,  0.,  0.]])
    """
    t = _times(t)
    L0 = checks.positive_float("inductance", inductance)
    C1, C2 = _capacitances(capacitances)
    q0 = checks.array("q0", q0, (3,))
    v0 = checks.array("v0", v0, (3,))
    C, V0, i0 = C1 + C2, q0[1] / C1, v0[0]
    kvl = abs(q0[1] / C1 - q0[2] / C2)
    if kvl > constraint_violation_tolerance(max(abs(q0[1] / C1), abs(q0[2] / C2))):
        raise InputError(f"`q0` must satisfy Kirchhoff's voltage law q_1/C_1 = q_2/C_2; the "
                         f"voltages differ by {kvl:.3e}.")
    _check_velocity(v0[0] - v0[1] - v0[2], np.abs(v0).max(),
                    "Kirchhoff's current law v_L = v_1 + v_2")
    w = 1 / np.sqrt(L0 * C)
    V = V0 * np.cos(w * t) + i0 / (C * w) * np.sin(w * t)
    i = i0 * np.cos(w * t) - C * w * V0 * np.sin(w * t)
    q = np.column_stack([q0[0] + C * (V - V0), C1 * V, C2 * V])
    v = np.column_stack([i, C1 / C * i, C2 / C * i])
    return q, v


def _capacitances(capacitances):
    """(C_1, C_2) as positive floats, or a ValueError naming `capacitances`."""
    if np.ndim(capacitances) != 1 or len(capacitances) != 2:
        raise InputError(f"`capacitances` must be a pair (C_1, C_2); got {capacitances!r}.")
    return tuple(checks.positive_float("capacitances", c) for c in capacitances)
