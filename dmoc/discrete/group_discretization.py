"""Discretization on the rotation group (second stage of the pipeline): for a `RigidBody`, the
discrete Lagrangian of the Lie group variational integrator written in the step's group
increment F_k = R_k^T R_{k+1} and its discrete torques, as named CasADi Functions whose last
input is the step h (one Function for every h).
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from ..mechanics.rigid_body import RigidBody
from ..mechanics.rotations import cayley_inverse, matrix_of

GROUP_RULES = ("midpoint",)


class GroupDiscretization:
    """Discrete data of a `RigidBody` on a uniform grid of step `h`; build it with
    `dmoc.discretize`.

    Attributes
    ----------
    system : RigidBody
    h : float
    rule : str
        ``"midpoint"``, the one rule on the group: the kinetic energy of the chord
        (F_k - I)/h and the potential by the trapezoid rule, below.
    order : int
        2.
    n_controls : int
        ``system.n_u``: one control u_k held on [t_k, t_{k+1}].
    discrete_lagrangian : casadi.Function
        ``L_d(q0, q1, F, h)``, scalar, with R_k, R_{k+1} the rotations whose rows are q0,
        q1 (9,) and F (9, the rows of F_k = R_k^T R_{k+1}) passed on its own, so that the
        increment is the exact group element the step produced, not a product of rounded
        rotations::

            L_d = (1/h) tr((I - F_k) J_d) - (h/2) (U(R_k) + U(R_{k+1})),
            J_d = tr(J)/2 I - J

        (Lee, Leok & McClamroch [1]_; for U = 0 the Moser-Veselov Lagrangian).
    discrete_force : casadi.Function
        ``f_d(q0, q1, F, u, h) -> (f_minus, f_plus)``, each (3,): the body torques at the
        two ends, (h/2) tau(R_k, xi_k, u_k) and (h/2) tau(R_{k+1}, xi_k, u_k), with the
        body angular velocity of the step xi_k = cay^{-1}(F_k)/h; their virtual work is
        f_minus . eta_k + f_plus . eta_{k+1} for the variations dR = R eta^.
    key : tuple
        ``(system.key, rule)``.

    References
    ----------
    .. [1] T. Lee, M. Leok, N. H. McClamroch, "Lie group variational integrators for the
       full body problem", Comput. Methods Appl. Mech. Engrg. 196 (2007) 2907-2924.
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
        self.discrete_lagrangian, self.discrete_force = functions

    def _functions(self):
        """(L_d, f_d) as Functions with h an input, built once per body."""
        body = self.system
        q0, q1, F9 = ca.SX.sym("q0", 9), ca.SX.sym("q1", 9), ca.SX.sym("F", 9)
        u, h = ca.SX.sym("u", body.n_u), ca.SX.sym("h")
        R0, R1, F = matrix_of(q0), matrix_of(q1), matrix_of(F9)
        J = body.inertia
        J_d = ca.DM(0.5 * np.trace(J) * np.eye(3) - J)
        L_d = ca.trace(ca.mtimes(ca.DM.eye(3) - F, J_d)) / h \
            - h / 2 * (body.potential(R0) + body.potential(R1))
        xi = cayley_inverse(F) / h
        f_minus, f_plus = (h / 2 * body.torque(R, xi, u) for R in (R0, R1))
        return (ca.Function("L_d", [q0, q1, F9, h], [L_d], ["q0", "q1", "F", "h"], ["L_d"]),
                ca.Function("f_d", [q0, q1, F9, u, h], [f_minus, f_plus],
                            ["q0", "q1", "F", "u", "h"], ["f_minus", "f_plus"]))

    def __repr__(self):
        return f"GroupDiscretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


_GROUP_DATA = BoundedCache(16, "group_discrete_data")
