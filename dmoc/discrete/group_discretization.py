"""Discretization on SO(3) x R^n_x (second stage of the pipeline): for a `RigidBody`, the
discrete Lagrangian of the Lie group variational integrator written in the step's group
increment F_k = R_k^T R_{k+1} and the vector increment x_{k+1} - x_k; for a system whose
kinetic energy depends on the configuration and couples Omega and x' (a
`FloatingBaseRobot`), its generalization at the midpoint on the group; their discrete forces
and discrete constraint one-forms, as named CasADi Functions whose last input is the step h
(one Function for every h).
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from .._util.typed_ops import divide, minus, plus, times
from ..mechanics.rigid_body import RigidBody
from ..mechanics.robots.floating_base import FloatingBaseRobot
from ..mechanics.rotations import cayley, cayley_half, cayley_inverse, matrix_of, split_configuration

GROUP_RULES = ("midpoint",)
GROUP_SYSTEMS = (RigidBody, FloatingBaseRobot)


class GroupDiscretization:
    """Discrete data of a `RigidBody` or a `FloatingBaseRobot` on a uniform grid of step
    `h`; build it with `dmoc.discretize`.

    Attributes
    ----------
    system : RigidBody or FloatingBaseRobot
    h : float
    rule : str
        ``"midpoint"``, the one rule on the group: the kinetic energy of the chords
        (F_k - I)/h and (x_{k+1} - x_k)/h, the potential by the trapezoid rule, below.
    order : int
        2.
    n_controls : int
        ``system.n_u``: one control u_k held on [t_k, t_{k+1}].
    discrete_lagrangian : casadi.Function
        ``L_d(q0, q1, F, h)``, scalar, with q0 = (rows of R_k, x_k), q1 = (rows of
        R_{k+1}, x_{k+1}) (9 + n_x each) and F (9, the rows of F_k = R_k^T R_{k+1})
        passed on its own, so that the increment is the exact group element the step
        produced, not a product of rounded rotations::

            L_d = (1/h) tr((I - F_k) J_d) + (1/2h) dx_k^T M dx_k
                  - (h/2) (U(R_k, x_k) + U(R_{k+1}, x_{k+1})),
            J_d = tr(J)/2 I - J,  dx_k = x_{k+1} - x_k

        (Lee, Leok & McClamroch [1]_, whose full body carries its position the same way;
        for U = 0 and n_x = 0 the Moser-Veselov Lagrangian). For a kinetic energy
        T(R, x, Omega, x') that depends on the configuration (a `FloatingBaseRobot`), the
        kinetic term is T at the step's midpoint on the group (`midpoint_kinetic_term`)::

            L_d = h T(R_k cay(g_k), (x_k + x_{k+1})/2, w_k/h, dx_k/h)
                  - (h/2) (U(R_k, x_k) + U(R_{k+1}, x_{k+1})),
            f_k = cay^{-1}(F_k),  g_k = f_k / (1 + c_k),  w_k = f_k / c_k,
            c_k = sqrt(1 + |f_k|^2/4),

        cay(g_k)^2 = F_k (g_k halves the rotation of F_k) and |w_k| = 2 sin(phi_k/2) the
        chord of the rotation by phi_k of F_k; for T = 1/2 Omega^T J Omega + 1/2 x'^T M x'
        it is the form above term by term (h T(w_k/h) = (1/h) tr((I - F_k) J_d)).
    discrete_force : casadi.Function
        ``f_d(q0, q1, F, u, h) -> (f_minus, f_plus)``, each (3 + n_x,): the generalized
        forces at the two ends, (h/2) tau(R_k, xi_k, x_k, v_k, u_k) and (h/2)
        tau(R_{k+1}, xi_k, x_{k+1}, v_k, u_k), with the step's body angular velocity
        xi_k = cay^{-1}(F_k)/h and v_k = dx_k/h; their virtual work is f_minus .
        (eta_k, dx_k) + f_plus . (eta_{k+1}, dx_{k+1}) for the variations dR = R eta^.
    discrete_constraint : casadi.Function
        ``omega_d(q0, q1, F, h) -> omega_d``, shape (m,): the one-forms by the trapezoid
        rule on the step's velocities, (1/2) (A(q_k) + A(q_{k+1})) (cay^{-1}(F_k);
        dx_k) / h, the retraction form of (28) [2]_ on the group (for the rolling ball,
        whose A involves R only through R_k cay^{-1}(F_k) = R_{k+1} cay^{-1}(F_k), both
        ends give the same rows).
    key : tuple
        ``(system.key, rule)``.

    References
    ----------
    .. [1] T. Lee, M. Leok, N. H. McClamroch, "Lie group variational integrators for the
       full body problem", Comput. Methods Appl. Mech. Engrg. 196 (2007) 2907-2924.
    .. [2] M. Leok, T. Ohsawa, "Variational and geometric structures of discrete Dirac
       mechanics", Found. Comput. Math. 11 (2011) 529-562.
    """

    order = 2

    def __init__(self, system, h, rule="midpoint"):
        checks.instance("system", system, GROUP_SYSTEMS, "a RigidBody or a FloatingBaseRobot")
        self.system = system
        self.h = checks.step_size("h", h)
        self.rule = checks.choice("rule", rule, GROUP_RULES)
        self.n_controls = system.n_u
        self.key = (system.key, self.rule)
        functions = _GROUP_DATA.get(self.key, self._functions)
        self.discrete_lagrangian, self.discrete_force, self.discrete_constraint = functions

    def _functions(self):
        """(L_d, f_d, omega_d) as Functions with h an input, built once per body."""
        body = self.system
        n_q = 9 + body.n_x
        q0, q1, F9 = ca.SX.sym("q0", n_q), ca.SX.sym("q1", n_q), ca.SX.sym("F", 9)
        u, h = ca.SX.sym("u", body.n_u), ca.SX.sym("h")
        (R0, x0), (R1, x1), F = split_configuration(q0), split_configuration(q1), matrix_of(F9)
        dx = minus(x1, x0)        # SX arithmetic through typed_ops: the operators' nodes
        kinetic = (_chord_kinetic_term(body, dx, F, h) if isinstance(body, RigidBody)
                   else midpoint_kinetic_term(body.kinetic_energy, R0, x0, x1, F, h))
        half_h = divide(h, 2.0)
        L_d = minus(kinetic, times(half_h, plus(body.potential(R0, x0), body.potential(R1, x1))))
        xi, v = divide(cayley_inverse(F), h), divide(dx, h)
        f_minus, f_plus = (times(half_h, body.torque(R, xi, x, v, u)) for R, x in ((R0, x0), (R1, x1)))
        A = times(0.5, plus(body.constraint_matrix(q0), body.constraint_matrix(q1)))
        omega_d = ca.mtimes(A, ca.vertcat(xi, v))
        return (ca.Function("L_d", [q0, q1, F9, h], [L_d], ["q0", "q1", "F", "h"], ["L_d"]),
                ca.Function("f_d", [q0, q1, F9, u, h], [f_minus, f_plus],
                            ["q0", "q1", "F", "u", "h"], ["f_minus", "f_plus"]),
                ca.Function("omega_d", [q0, q1, F9, h], [omega_d], ["q0", "q1", "F", "h"],
                            ["omega_d"]))

    def __repr__(self):
        return f"GroupDiscretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


def _chord_kinetic_term(body, dx, F, h):
    """(1/h) tr((I - F) J_d) + (1/2h) dx^T M dx of a RigidBody, J_d = tr(J)/2 I - J [1]."""
    J = body.inertia
    J_d = ca.DM(0.5 * np.trace(J) * np.eye(3) - J)
    return (ca.trace(ca.mtimes(ca.DM.eye(3) - F, J_d))
            + 0.5 * ca.dot(dx, ca.mtimes(ca.DM(body.mass_matrix), dx))) / h


def midpoint_kinetic_term(kinetic_energy, R0, x0, x1, F, h):
    """h T(R_k cay(g_k), (x_k + x_{k+1})/2, w_k/h, (x_{k+1} - x_k)/h), the kinetic part of
    the discrete Lagrangian of a configuration-dependent kinetic energy on SO(3) x R^n_x.

    Parameters
    ----------
    kinetic_energy : casadi.Function
        ``T(R, x, omega, v)``, R (3, 3), x and v (n_x,), omega the body angular velocity (3,).
    R0 : casadi.SX, shape (3, 3)
    x0, x1 : casadi.SX, shape (n_x, 1)
    F : casadi.SX, shape (3, 3)
        The increment R_k^T R_{k+1}.
    h : casadi.SX

    Returns
    -------
    casadi.SX
        The scalar term.

    Notes
    -----
    With f = cay^{-1}(F) and c = sqrt(1 + |f|^2/4) (F turns by phi = 2 atan(|f|/2)), the
    midpoint rotation is R_k cay(f/(1 + c)), the square root of F applied to R_k
    (`dmoc.mechanics.rotations.cayley_half`), equal to R_{k+1} cay(-f/(1 + c)), and the
    angular velocity w/h = f/(c h), |w| = 2 sin(phi/2): the two ends enter alike, so L_d is
    symmetric (L_d(q_{k+1}, q_k, -h) = -L_d(q_k, q_{k+1}, h)) and its local error O(h^3)
    makes the integrator of order 2. The midpoint, w and dx turn with the configuration as
    R, Omega and x' do (R_k -> Q R_k gives R_mid -> Q R_mid, F unchanged), so every symmetry
    of L passes to L_d and its discrete momentum maps are kept exactly (discrete Noether):
    for a floating base, translations p -> p + c and, without gravity, rotations (R, p) ->
    (Q R, Q p).
    """
    f = cayley_inverse(F)
    c = ca.sqrt(1 + ca.dot(f, f) / 4)
    R_mid = ca.mtimes(R0, cayley(cayley_half(f)))
    return h * kinetic_energy(R_mid, (x0 + x1) / 2, f / (c * h), (x1 - x0) / h)


_GROUP_DATA = BoundedCache(16, "group_discrete_data")
