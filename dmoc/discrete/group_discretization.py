"""Discretization on SO(3) x R^n_x (second stage of the pipeline): for a `RigidBody`, the
discrete Lagrangian of the Lie group variational integrator written in the step's group
increment F_k = R_k^T R_{k+1} and the vector increment x_{k+1} - x_k, its discrete forces
and its discrete constraint one-forms, as named CasADi Functions whose last input is the
step h (one Function for every h).
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from ..mechanics.rigid_body import RigidBody
from ..mechanics.rotations import cayley_inverse, matrix_of, split_configuration

GROUP_RULES = ("midpoint",)


class GroupDiscretization:
    """Discrete data of a `RigidBody` on a uniform grid of step `h`; build it with
    `dmoc.discretize`.

    Attributes
    ----------
    system : RigidBody
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
        for U = 0 and n_x = 0 the Moser-Veselov Lagrangian).
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
        checks.instance("system", system, RigidBody, "a RigidBody")
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
        J, dx = body.inertia, x1 - x0
        J_d = ca.DM(0.5 * np.trace(J) * np.eye(3) - J)
        L_d = ca.trace(ca.mtimes(ca.DM.eye(3) - F, J_d)) / h \
            + 0.5 * ca.dot(dx, ca.mtimes(ca.DM(body.mass_matrix), dx)) / h \
            - h / 2 * (body.potential(R0, x0) + body.potential(R1, x1))
        xi, v = cayley_inverse(F) / h, dx / h
        f_minus, f_plus = (h / 2 * body.torque(R, xi, x, v, u) for R, x in ((R0, x0), (R1, x1)))
        A = 0.5 * (body.constraint_matrix(q0) + body.constraint_matrix(q1))
        omega_d = ca.mtimes(A, ca.vertcat(xi, v))
        return (ca.Function("L_d", [q0, q1, F9, h], [L_d], ["q0", "q1", "F", "h"], ["L_d"]),
                ca.Function("f_d", [q0, q1, F9, u, h], [f_minus, f_plus],
                            ["q0", "q1", "F", "u", "h"], ["f_minus", "f_plus"]),
                ca.Function("omega_d", [q0, q1, F9, h], [omega_d], ["q0", "q1", "F", "h"],
                            ["omega_d"]))

    def __repr__(self):
        return f"GroupDiscretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


_GROUP_DATA = BoundedCache(16, "group_discrete_data")
