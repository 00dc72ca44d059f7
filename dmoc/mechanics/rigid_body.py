"""A rigid body on SO(3) x R^n_x (first stage of the pipeline): a rotation R carried as a
group element, optionally with vector coordinates x (the position of a contact point or of
the centre), its body-frame inertia J, the mass matrix M of x, a potential U(R, x),
generalized forces and constraint one-forms, each turned once into a named CasADi Function.
Its Lagrangian is L = 1/2 Omega^T J Omega + 1/2 x'^T M x' - U(R, x) with R' = R Omega^
(Omega the body angular velocity), its constraints A_Omega(R, x) Omega + A_x(R, x) x' = 0;
the discretization on the group is `dmoc.discrete.GroupDiscretization`.
"""

import functools

import casadi as ca
import numpy as np

from .._util import checks
from .._util.symbolic import user_function
from ..errors import InputError
from .rotations import matrix_of
from .system import _check_rank, _fingerprint


class RigidBody:
    """A rigid body, its rotations R in SO(3) carried as group elements, with optional vector
    coordinates x in R^n_x and constraint one-forms (a ball rolling on a plane).

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        The body-frame inertia tensor J (symmetric positive definite) about the fixed point
        or, with coordinates, about the point whose motion x describes; or its principal
        moments (J = diag(inertia)).
    potential : callable, optional
        ``potential(R)``, or ``potential(R, x)`` with coordinates, R a CasADi (3, 3) symbol
        and x (n_x, 1), returning the scalar U (e.g. gravity on the heavy top,
        m g e3 . R rho). None: U = 0.
    torque : callable, optional
        ``torque(R, omega, u)`` returning the body-frame torque (3,) that is not the
        gradient of U (controls, friction), omega the body angular velocity (3, 1) and u
        the controls (n_u, 1); with coordinates ``torque(R, omega, x, v, u)``, v = x'
        (n_x, 1), returning the generalized force (3 + n_x,): the body torque, then the
        force along x.
    n_u : int, optional
        Number of controls.
    coordinates : array_like, shape (n_x,) or (n_x, n_x), optional
        The mass matrix M of the vector coordinates x (symmetric positive definite; a
        vector gives diag): the kinetic energy gains 1/2 x'^T M x'. None: n_x = 0.
    constraints : callable, optional
        ``constraints(R)``, or ``constraints(R, x)`` with coordinates, returning A (m,
        3 + n_x) with linearly independent rows: the one-forms A (Omega; x') = 0 in the
        body angular velocity Omega and x'. A one-form in the spatial angular velocity
        omega = R Omega is written with R (the rolling ball: x' = r P (R Omega x e3)).
    name : str, optional
        What messages and ``repr`` call the body.

    Attributes
    ----------
    inertia : numpy.ndarray, shape (3, 3)
    mass_matrix : numpy.ndarray, shape (n_x, n_x)
    n_x, n, m, n_u : int
        Vector coordinates, degrees of freedom n = 3 + n_x (the body angular velocity and
        x'), constraint rows and controls.
    potential : casadi.Function
        ``U(R, x) -> U``, R a (3, 3) matrix, x (n_x,).
    torque : casadi.Function
        ``tau(R, omega, x, v, u) -> tau``, shape (3 + n_x,).
    constraint_matrix : casadi.Function
        ``A(q) -> A``, shape (m, 3 + n_x), q (9 + n_x,) the rows of R then x.
    kinetic_energy : casadi.Function
        ``T(R, x, omega, v) -> T``: 1/2 omega^T J omega + 1/2 v^T M v.
    generalized_mass : casadi.Function
        ``M(q) -> M``, shape (n, n): the mass matrix diag(J, M) of the velocity (Omega, x'),
        constant (a `FloatingBaseRobot`'s depends on q).
    energy : casadi.Function
        ``energy(q, p) -> E``: 1/2 Pi^T J^{-1} Pi + 1/2 p_x^T M^{-1} p_x + U(R, x) of
        q = (rows of R, x) (9 + n_x,) and the momentum p = (Pi, p_x) (3 + n_x,), Pi = J
        Omega the body angular momentum, p_x = M x'.
    key : str
        Identifies the body's data: the discretization, the step residual and the
        compiled steps are shared between equal bodies.

    Examples
    --------
    >>> import dmoc
    >>> body = dmoc.RigidBody([1.0, 2.0, 3.0])
    >>> body
    RigidBody('rigid body', inertia=diag(1, 2, 3), n_u=0)
    """

    def __init__(self, inertia, *, potential=None, torque=None, n_u=0, coordinates=None,
                 constraints=None, name="rigid body"):
        self.inertia = _inertia(inertia)
        self.mass_matrix = (np.zeros((0, 0)) if coordinates is None
                            else _positive_definite("coordinates", coordinates))
        self.n_x = self.mass_matrix.shape[0]
        self.n, self.n_u = 3 + self.n_x, checks.nonnegative_int("n_u", n_u)
        self.name = str(name)
        sym = {"R": ca.SX.sym("R", 3, 3), "omega": ca.SX.sym("omega", 3),
               "x": ca.SX.sym("x", self.n_x), "v": ca.SX.sym("v", self.n_x),
               "u": ca.SX.sym("u", self.n_u)}
        user = {}
        given = {"potential": (potential or (lambda *a: 0), ("R", "x"), (1, 1), "U"),
                 "torque": (torque or (lambda *a: ca.SX.zeros(self.n)),
                            ("R", "omega", "x", "v", "u"), (self.n, 1), "tau"),
                 "constraints": (constraints or (lambda *a: ca.SX(0, self.n)), ("R", "x"),
                                 (None, self.n), "A")}
        problems = []
        for arg, (fun, names, shape, label) in given.items():
            names = self._passed(names)
            user[arg] = user_function(arg, fun, [sym[k] for k in names], names, shape,
                                       problems, label=label)
        if problems:
            raise InputError(" ".join(problems))
        q = ca.SX.sym("q", 9 + self.n_x)
        on_q = {"R": matrix_of(q[:9]), "x": q[9:]}
        self.potential = self._full(user["potential"], ("R", "x"), sym)
        self.torque = self._full(user["torque"], ("R", "omega", "x", "v", "u"), sym)
        A = user["constraints"](*[on_q[k] for k in self._passed(("R", "x"))])
        self.constraint_matrix = ca.Function("A", [q], [A], ["q"], ["A"])
        self.m = A.size1()
        _check_rank(self.constraint_matrix, 9 + self.n_x, 0, problems)    # at random q, as on R^n
        if problems:
            raise InputError(" ".join(problems))
        self._mass = ca.DM(np.asarray(block_diagonal(self.inertia, self.mass_matrix)))
        self.generalized_mass = ca.Function("M", [q], [self._mass], ["q"], ["M"])
        # the mass matrix (J and M as its constants) stands for the energy's data
        self.key = _fingerprint(self.potential, self.torque, self.constraint_matrix, self.generalized_mass)

    @functools.cached_property
    def kinetic_energy(self):
        """``T(R, x, omega, v)`` (made on first use: the body's discretization writes its
        chord term from J and M, `GroupDiscretization`)."""
        R, x, omega, v = (ca.SX.sym("R", 3, 3), ca.SX.sym("x", self.n_x), ca.SX.sym("omega", 3),
                          ca.SX.sym("v", self.n_x))
        velocity = ca.vertcat(omega, v)
        return ca.Function("T", [R, x, omega, v], [0.5 * ca.bilin(self._mass, velocity, velocity)],
                           ["R", "x", "omega", "v"], ["T"])

    @functools.cached_property
    def energy(self):
        """``energy(q, p) -> E`` (made on first use: a solve neither reads)."""
        q, p = ca.SX.sym("q", 9 + self.n_x), ca.SX.sym("p", self.n)
        kinetic = 0.5 * ca.dot(p, ca.solve(self._mass, p))
        return ca.Function("energy", [q, p], [kinetic + self.potential(matrix_of(q[:9]), q[9:])],
                           ["q", "p"], ["E"])

    def _passed(self, names):
        """The arguments of a user callable: x and v only when the body has coordinates."""
        return tuple(k for k in names if self.n_x or k not in ("x", "v"))

    def _full(self, function, names, sym):
        """`function` of the passed arguments as a Function of all of `names` (itself when
        it takes them all)."""
        if self._passed(names) == tuple(names):
            return function
        out = function(*[sym[k] for k in self._passed(names)])
        label = function.name_out(0)
        return ca.Function(label, [sym[k] for k in names], [out], list(names), [label])

    def __repr__(self):
        J = self.inertia
        shown = ("diag(" + ", ".join(f"{x:g}" for x in np.diag(J)) + ")"
                 if not np.any(J - np.diag(np.diag(J))) else np.array2string(J, separator=", "))
        extra = f", n_x={self.n_x}, m={self.m}" if self.n_x or self.m else ""
        return f"RigidBody({self.name!r}, inertia={shown}, n_u={self.n_u}{extra})"


ALLOWED_VELOCITY = 1e-10    # |A(q) v| accepted of a velocity a user gives, relative to 1 + |v|


def check_allowed_velocity(body, q, v, given):
    """InputError unless the velocity v = (Omega, x') (3 + n_x,) satisfies the body's
    constraints at q (9 + n_x,), A(q) v = 0 to ALLOWED_VELOCITY; `given` names the
    arguments v came from."""
    if not np.any(v):               # at rest: allowed whatever A (no evaluation)
        return
    defect = np.abs(np.array(body.constraint_matrix(q)) @ v).max(initial=0.0)
    if defect > ALLOWED_VELOCITY * (1 + np.abs(v).max()):
        raise InputError(f"the velocity of {given} must satisfy the constraints A(q) v = 0 of "
                         f"{body.name!r}; got |A(q) v| = {defect:.2e}.")


def block_diagonal(J, M):
    """The mass matrix diag(J, M) of the velocity (Omega, x'), shape (3 + n_x, 3 + n_x)."""
    n_x = M.shape[0]
    return np.block([[J, np.zeros((3, n_x))], [np.zeros((n_x, 3)), M]])


def _inertia(value):
    """`value` as a symmetric positive definite (3, 3) array; principal moments (3,) give
    the diagonal one."""
    J = checks.real_array("inertia", value, "principal moments (3,) or a (3, 3) inertia tensor")
    return _positive_definite("inertia", checks.array("inertia", np.diag(J) if J.shape == (3,)
                                                      else J, (3, 3)))


def _positive_definite(name, value):
    """`value` as a symmetric positive definite (k, k) array; a vector (k,) gives the
    diagonal one."""
    M = checks.real_array(name, value, "a vector (k,) or a symmetric positive definite (k, k) matrix")
    M = np.diag(M) if M.ndim == 1 else M
    if M.ndim != 2 or M.shape[0] != M.shape[1] or M.size == 0:
        raise InputError(f"`{name}` must be a vector (k,) or a square (k, k) matrix, k >= 1; "
                         f"got shape {M.shape}.")
    if np.abs(M - M.T).max() > 1e-12 * np.abs(M).max() or np.linalg.eigvalsh(M).min() <= 0:
        raise InputError(f"`{name}` must be symmetric positive definite; got eigenvalues "
                         f"{np.linalg.eigvals(M).round(6).tolist()} and asymmetry "
                         f"{np.abs(M - M.T).max():.2e}.")
    return M
