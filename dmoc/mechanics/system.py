"""Continuous mechanical data, the first stage of the pipeline: a Lagrangian L(q, v),
constraint one-forms A(q) whose rows are the omega^a of (27), holonomic constraints g(q) = 0
(whose one-forms dg join them), and a generalized force f(q, v, u), each turned once into a
named CasADi Function.
"""

import hashlib

import casadi as ca
import numpy as np

from .._util import checks
from .._util.symbolic import user_function
from ..errors import InputError
from .bodies import system_bodies
from .labels import control_names, coordinate_names
from .units import system_units


class MechanicalSystem:
    """A Lagrangian system with linear velocity constraints and forces, on Q = R^n.

    Parameters
    ----------
    lagrangian : callable
        ``lagrangian(q, v)`` with CasADi column symbols q, v of shape (n, 1), returning a
        scalar expression. It may be degenerate (d^2L/dv^2 singular): it is never inverted.
    n : int
        Dimension of the configuration space.
    constraints : callable, optional
        ``constraints(q)`` returning the (m - k, n) matrix of the nonholonomic constraint
        one-forms omega^a (27).
    holonomic : callable, optional
        ``holonomic(q)`` returning g(q), shape (k,): the configurations are restricted to
        g(q) = 0. The discretization keeps g(q_j) = 0 at every node exactly (not only its
        one-forms dg = dg/dq dq), see docs/holonomic.md.
    force : callable, optional
        ``force(q, v, u)`` returning the generalized force, shape (n,), with u of shape
        (n_u, 1).
    n_u : int, optional
        Number of controls.
    names : sequence of str, optional
        Names of the n coordinates, for plots, messages and the CSV table's columns:
        distinct, without commas or line breaks.
    units : mapping, optional
        Units for plots and animations: "t" (str, time), "q" (n str, the coordinates), "u"
        (n_u str, the controls); a missing key means no unit, e.g.
        ``{"t": "s", "q": ("m", "m", "rad"), "u": ("N", "N m")}``.
    control_names : sequence of str, optional
        Names of the n_u controls, for plots and the CSV table (rules of `names`); default
        u0, u1, ...
    bodies : sequence of Body, optional
        What plots and animations draw of the system: outlines in the plane as functions
        of q (`dmoc.Body`), each tried at q = 0 here (docs/stages/results.md).

    Attributes
    ----------
    n, m, n_u : int
        Sizes of q, of lam (number of constraint one-forms, nonholonomic and holonomic) and
        of u.
    n_holonomic : int
        k, the number of holonomic constraints (the last k of the m one-forms).
    names, control_names : tuple of str
        n and n_u names.
    bodies : tuple of Body
        The declared bodies, () when none.
    units : dict
        {"t": str, "q": tuple of n str, "u": tuple of n_u str}, "" where none was declared.
    lagrangian, constraint_matrix, force, momentum, energy : casadi.Function
        ``L(q, v)``, ``A(q)`` (m, n), ``f(q, v, u)`` (n,), ``p = dL/dv(q, v)`` (n,) and
        ``E = v . dL/dv - L`` built once on symbols of the declared sizes. The rows of A(q)
        are all the constraint one-forms: those of `constraints`, then dg/dq (k, n).
        Allowed velocities are ker A(q), constraint forces A(q)^T lam.
    nonholonomic_matrix, holonomic : casadi.Function
        ``A_nh(q)`` (m - k, n), the rows given by `constraints`, and ``g(q)`` (k,).
    key : str
        A fingerprint of L, A_nh, g and f (not of `names`): systems with equal data share
        their step residuals and compiled steps.
    momentum_residual_units : str
        ``"momentum"``: `momentum_residual` p - dL/dv is in units of momentum.

    Raises
    ------
    ValueError, TypeError
        Every problem found while evaluating the callables on symbols, reported at once.

    Examples
    --------
    >>> import casadi as ca
    >>> s = MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 2,
    ...                      constraints=lambda q: ca.horzcat(1, -1))
    >>> (s.n, s.m, s.n_u)
    (2, 1, 0)
    >>> bead = MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) - q[1], 2,
    ...                         holonomic=lambda q: q[1] - q[0] ** 3)
    >>> (bead.m, bead.n_holonomic)
    (1, 1)
    """

    def __init__(self, lagrangian, n, *, constraints=None, holonomic=None, force=None, n_u=0,
                 names=None, units=None, control_names=None, bodies=None):
        q, v = _build_data(self, "MechanicalSystem", ("lagrangian", "L", lagrangian, "v"), n,
                           constraints, holonomic, force, n_u,
                           (names, units, control_names, bodies))
        L = self.lagrangian(q, v)
        p = ca.gradient(L, v)
        self.momentum = ca.Function("momentum", [q, v], [p], ["q", "v"], ["p"])
        self.energy = ca.Function("energy", [q, v], [ca.dot(v, p) - L], ["q", "v"], ["E"])
        self.key = _fingerprint(self.lagrangian, self.nonholonomic_matrix, self.holonomic, self.force)

    momentum_residual_units = "momentum"

    def momentum_residual(self, q, p, v):
        """p - dL/dv(q, v): zero when p is the momentum of the velocity v at q."""
        return p - self.momentum(q, v)

    def inertia(self, q):
        """diag d2L/dv2 (q, 0), shape (n, 1), an SX expression in the symbols q (n, 1): the
        inertia of each coordinate at q (zero in degenerate directions), for the scaling of
        the optimizer's NLP (`dmoc.optimal_control.nlp.scaling`)."""
        return _hessian_diagonal(self.lagrangian, q, self.n)

    def __repr__(self):
        return (f"MechanicalSystem(n={self.n}, m={self.m}, n_holonomic={self.n_holonomic}, "
                f"n_u={self.n_u}, names={self.names})")


class HamiltonianSystem:
    """A Hamiltonian system with linear velocity constraints, holonomic constraints and
    forces, on T*Q with Q = R^n: the data of the implicit Hamiltonian systems that (38)/(42)
    discretize.

    Parameters
    ----------
    hamiltonian : callable
        ``hamiltonian(q, p)`` with column symbols q, p of shape (n, 1), a scalar expression.
    n : int
    constraints, holonomic : callable, optional
        As for `MechanicalSystem`: A_nh(q) (m - k, n) and g(q) (k,).
    force : callable, optional
        ``force(q, p, u)``, shape (n,).
    n_u : int, optional
    names, control_names : sequence of str, optional
    units : mapping, optional
    bodies : sequence of Body, optional
        As for `MechanicalSystem`.

    Attributes
    ----------
    n, m, n_u, n_holonomic, names, control_names, units, bodies, key
        As for `MechanicalSystem`.
    hamiltonian, constraint_matrix, nonholonomic_matrix, holonomic, force : casadi.Function
        ``H(q, p)``, ``A(q)`` (m, n), ``A_nh(q)``, ``g(q)``, ``f(q, p, u)``.
    velocity : casadi.Function
        ``v = dH/dp(q, p)`` (n,).
    momentum : casadi.Function
        ``p(q, v)`` by one Newton step on dH/dp(q, p) = v from p = 0: exact when H is
        quadratic in p (mechanical systems), a guess otherwise; used for initial guesses.
    momentum_residual_units : str
        ``"velocity"``: `momentum_residual` dH/dp - v is in units of velocity.

    Examples
    --------
    >>> import casadi as ca
    >>> s = HamiltonianSystem(lambda q, p: 0.5 * ca.dot(p, p) - ca.cos(q[0]), 1)
    >>> float(s.velocity(0.3, 2.0))
    2.0
    """

    def __init__(self, hamiltonian, n, *, constraints=None, holonomic=None, force=None, n_u=0,
                 names=None, units=None, control_names=None, bodies=None):
        q, p = _build_data(self, "HamiltonianSystem", ("hamiltonian", "H", hamiltonian, "p"), n,
                           constraints, holonomic, force, n_u,
                           (names, units, control_names, bodies))
        v = ca.SX.sym("v", self.n)
        dH = ca.gradient(self.hamiltonian(q, p), p)
        self.velocity = ca.Function("velocity", [q, p], [dH], ["q", "p"], ["v"])
        at_rest = ca.substitute(dH, p, ca.SX.zeros(self.n))
        step = ca.solve(ca.substitute(ca.jacobian(dH, p), p, ca.SX.zeros(self.n)), v - at_rest)
        self.momentum = ca.Function("momentum", [q, v], [step], ["q", "v"], ["p"])
        self.key = _fingerprint(self.hamiltonian, self.nonholonomic_matrix, self.holonomic, self.force)

    momentum_residual_units = "velocity"

    def momentum_residual(self, q, p, v):
        """dH/dp(q, p) - v: zero when p is the momentum of the velocity v at q."""
        return self.velocity(q, p) - v

    def inertia(self, q):
        """1 / diag d2H/dp2 (q, 0), shape (n, 1), an SX expression in the symbols q (n, 1):
        the inertia of each coordinate at q (infinite where H does not depend on that
        momentum), for the scaling of the optimizer's NLP (`dmoc.optimal_control.nlp.scaling`)."""
        return 1 / _hessian_diagonal(self.hamiltonian, q, self.n)

    def __repr__(self):
        return (f"HamiltonianSystem(n={self.n}, m={self.m}, n_holonomic={self.n_holonomic}, "
                f"n_u={self.n_u}, names={self.names})")


def _hessian_diagonal(function, q, n):
    """diag d2 function(q, y)/dy2 at (q, y = 0), shape (n, 1), in the symbols q."""
    y = ca.SX.sym("y", n)
    return ca.substitute(ca.diag(ca.hessian(function(q, y), y)[0]), y, ca.SX.zeros(n))


def _build_data(system, kind, primary, n, constraints, holonomic, force, n_u, drawn):
    """Set the data every system class shares on `system` (n, n_u, the primary Function L
    or H, the constraints, the force, names, units, control names, bodies, m, n_holonomic),
    reporting every problem at once; return the symbols (q, x), x the second argument (v or
    p) of L or H and f.

    `primary` is (argument name, Function label, callable, name of x); `drawn` is (names,
    units, control_names, bodies), what plots show."""
    system.n = checks.positive_int("n", n)
    system.n_u = checks.nonnegative_int("n_u", n_u)
    name, label, fun, second = primary
    q, x, u = ca.SX.sym("q", system.n), ca.SX.sym(second, system.n), ca.SX.sym("u", system.n_u)
    problems = []
    if fun is None:
        problems.append(f"`{name}` is required: a callable returning a CasADi expression.")
    else:
        primary_function = user_function(name, fun, (q, x), ("q", second), (1, 1), problems,
                                         label=label)
        setattr(system, name, primary_function)
        if primary_function is not None and not ca.depends_on(primary_function(q, x), x):
            problems.append(f"`{name}` must depend on the {'velocities v' if second == 'v' else 'momenta p'}: "
                            f"without them there is no motion to discretize (no step map).")
    (system.nonholonomic_matrix, system.holonomic,
     system.constraint_matrix) = constraint_functions(q, constraints, holonomic, problems)
    args, before = ("q", second, "u"), len(problems)
    system.force = ca.Function("f", [q, x, u], [ca.SX.zeros(system.n)], args, ["f"]) \
        if force is None else user_function("force", force, (q, x, u), args, (system.n, 1),
                                            problems, label="f")
    if len(problems) > before and system.n_u == 0:      # a force reading u, n_u forgotten
        problems[-1] = problems[-1].rstrip(".") + (". With n_u = 0 the force is called with u of "
                                                   "shape (0,): if it reads u, declare the number of controls, n_u=k.")
    names, units, controls, bodies = drawn
    system.names = coordinate_names(names, system.n, problems)
    system.control_names = control_names(controls, system.n_u, problems)
    system.units = system_units(units, system.n, system.n_u, problems)
    system.bodies = system_bodies(bodies, system.n, problems)
    if not problems:
        _check_rank(system.constraint_matrix, system.n, system.holonomic.numel_out(0), problems)
    if problems:
        raise InputError(f"{kind} is invalid:\n  - " + "\n  - ".join(problems))
    system.m = system.constraint_matrix.size1_out(0)
    system.n_holonomic = system.holonomic.numel_out(0)
    return q, x


def constraint_functions(q, constraints, holonomic, problems):
    """The constraint data of a system on Q = R^n from the user's callables.

    Parameters
    ----------
    q : casadi.SX, shape (n, 1)
    constraints, holonomic : callable or None
        ``constraints(q) -> A_nh`` (m - k, n) and ``holonomic(q) -> g`` (k,).
    problems : list of str
        Messages are appended here (the caller raises them together).

    Returns
    -------
    nonholonomic, holonomic, one_forms : casadi.Function or None
        ``A_nh(q)``, ``g(q)`` and ``A(q) = [A_nh(q); dg/dq(q)]`` (m, n), the one-forms at
        the d'Alembert node; None where a callable failed. Shared by every system class,
        so the Lagrangian and Hamiltonian sides take the same arguments.
    """
    n = q.numel()
    A_nh = ca.Function("A_nh", [q], [ca.SX(0, n)], ["q"], ["A_nh"]) if constraints is None \
        else user_function("constraints", constraints, (q,), ("q",), (None, n), problems,
                           label="A_nh")
    g = ca.Function("g", [q], [ca.SX(0, 1)], ["q"], ["g"]) if holonomic is None \
        else user_function("holonomic", holonomic, (q,), ("q",), (None, 1), problems, label="g")
    if A_nh is None or g is None:
        return A_nh, g, None
    A = ca.vertcat(A_nh(q), ca.jacobian(g(q), q))
    return A_nh, g, ca.Function("A", [q], [A], ["q"], ["A"])


def _fingerprint(*functions):
    """A value that identifies the system's data: equal for systems built from the same
    expressions, so that residuals and compiled steps are shared between them."""
    return hashlib.sha256("".join(f.serialize() for f in functions).encode()).hexdigest()


def _check_rank(constraint_matrix, n, n_holonomic, problems):
    """A problem if the constraint one-forms (the rows of A(q), dg/dq included) are dependent
    at random configurations (the step equations would then be singular)."""
    rng = np.random.default_rng(0)
    m = constraint_matrix.size1_out(0)
    # the 3 points in one call of the mapped Function, one rank of the stack
    points = rng.normal(size=(3, n)).T
    ranks = np.linalg.matrix_rank(np.stack(np.hsplit(np.array(constraint_matrix.map(3)(points)), 3))) \
        if m else np.zeros(3, int)
    if m and ranks.max() < m:
        rows = "`constraints` must have linearly independent rows" if not n_holonomic else \
            "the rows of `constraints` and of dg/dq of `holonomic` must be linearly independent"
        problems.append(f"{rows}: A(q) has rank {ranks.max()} < m = {m} at random q; drop the "
                        f"redundant rows.")
