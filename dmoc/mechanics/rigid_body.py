"""A rigid body turning about a fixed point, configuration space SO(3) (first stage of the
pipeline): its body-frame inertia J, a potential U(R) and body torques tau(R, Omega, u),
each turned once into a named CasADi Function. Its Lagrangian is
L(R, Omega) = 1/2 Omega^T J Omega - U(R) with R' = R Omega^ (Omega the body angular
velocity); the discretization on the group is `dmoc.discrete.GroupDiscretization`.
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.symbolic import user_function
from ..errors import InputError
from .rotations import matrix_of
from .system import _fingerprint


class RigidBody:
    """A rigid body with a fixed point, its rotations R in SO(3) carried as group elements.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        The body-frame inertia tensor J about the fixed point (symmetric positive
        definite), or its principal moments (J = diag(inertia)).
    potential : callable, optional
        ``potential(R)`` with R a CasADi (3, 3) symbol, returning the scalar U(R) (e.g.
        gravity on the heavy top, m g e3 . R rho). None: U = 0.
    torque : callable, optional
        ``torque(R, omega, u)`` with R (3, 3), the body angular velocity omega (3, 1) and
        the controls u (n_u, 1), returning the body-frame torque (3,) that is not the
        gradient of U (controls, friction).
    n_u : int, optional
        Number of controls.
    name : str, optional
        What messages and ``repr`` call the body.

    Attributes
    ----------
    inertia : numpy.ndarray, shape (3, 3)
    n, n_u : int
        Degrees of freedom (3: the body angular velocity) and number of controls.
    potential : casadi.Function
        ``U(R) -> U``, R a (3, 3) matrix.
    torque : casadi.Function
        ``tau(R, omega, u) -> tau``, shape (3,).
    energy : casadi.Function
        ``energy(q, p) -> E``: 1/2 Pi^T J^{-1} Pi + U(R) of the rotation whose rows are q
        (9,) and the body angular momentum p = Pi = J Omega (3,).
    key : str
        Identifies the body's data (inertia, U, tau): the discretization, the step
        residual and the compiled steps are shared between equal bodies.

    Examples
    --------
    >>> import dmoc
    >>> body = dmoc.RigidBody([1.0, 2.0, 3.0])
    >>> body
    RigidBody('rigid body', inertia=diag(1, 2, 3), n_u=0)
    """

    n = 3

    def __init__(self, inertia, *, potential=None, torque=None, n_u=0, name="rigid body"):
        self.inertia = _inertia(inertia)
        self.n_u = checks.nonnegative_int("n_u", n_u)
        self.name = str(name)
        R, omega, u = ca.SX.sym("R", 3, 3), ca.SX.sym("omega", 3), ca.SX.sym("u", self.n_u)
        problems = []
        self.potential = user_function("potential", potential or (lambda R: 0), [R], ["R"],
                                       (1, 1), problems, label="U")
        self.torque = user_function("torque", torque or (lambda R, omega, u: ca.SX.zeros(3)),
                                    [R, omega, u], ["R", "omega", "u"], (3, 1), problems,
                                    label="tau")
        if problems:
            raise InputError(" ".join(problems))
        q, p = ca.SX.sym("q", 9), ca.SX.sym("p", 3)
        kinetic = 0.5 * ca.dot(p, ca.solve(ca.DM(self.inertia), p))
        self.energy = ca.Function("energy", [q, p], [kinetic + self.potential(matrix_of(q))],
                                  ["q", "p"], ["E"])
        self.key = _fingerprint(self.potential, self.torque, self.energy)

    def __repr__(self):
        J = self.inertia
        shown = ("diag(" + ", ".join(f"{x:g}" for x in np.diag(J)) + ")"
                 if not np.any(J - np.diag(np.diag(J))) else np.array2string(J, separator=", "))
        return f"RigidBody({self.name!r}, inertia={shown}, n_u={self.n_u})"


def _inertia(value):
    """`value` as a symmetric positive definite (3, 3) array; principal moments (3,) give
    the diagonal one."""
    J = checks.real_array("inertia", value, "principal moments (3,) or a (3, 3) inertia tensor")
    if J.shape == (3,):
        J = np.diag(J)
    J = checks.array("inertia", J, (3, 3))
    if np.abs(J - J.T).max() > 1e-12 * np.abs(J).max() or np.linalg.eigvalsh(J).min() <= 0:
        raise InputError(f"`inertia` must be symmetric positive definite; got eigenvalues "
                         f"{np.linalg.eigvals(J).round(6).tolist()} and asymmetry "
                         f"{np.abs(J - J.T).max():.2e}.")
    return J
