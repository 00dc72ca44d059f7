"""Continuous mechanical data, the first stage of the pipeline: a Lagrangian L(q, v),
constraint one-forms A(q) whose rows are the omega^a of (27), and a generalized force
f(q, v, u), each turned once into a named CasADi Function.
"""

import casadi as ca
import numpy as np

from . import _checks


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
        ``constraints(q)`` returning the (m, n) matrix A(q) whose rows are the constraint
        one-forms omega^a (27): allowed velocities are ker A(q), constraint forces A(q)^T lam.
    force : callable, optional
        ``force(q, v, u)`` returning the generalized force, shape (n,), with u of shape
        (n_u, 1).
    n_u : int, optional
        Number of controls.
    names : sequence of str, optional
        Names of the n coordinates, for plots and messages.

    Attributes
    ----------
    n, m, n_u : int
        Sizes of q, of lam (number of constraints) and of u.
    lagrangian, constraint_matrix, force, momentum, energy : casadi.Function
        ``L(q, v)``, ``A(q)`` (m, n), ``f(q, v, u)`` (n,), ``p = dL/dv(q, v)`` (n,) and
        ``E = v . dL/dv - L`` built once on symbols of the declared sizes.

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
    """

    def __init__(self, lagrangian, n, *, constraints=None, force=None, n_u=0, names=None):
        self.n = _checks.positive_int("n", n)
        self.n_u = _checks.nonnegative_int("n_u", n_u)
        q = ca.SX.sym("q", self.n)
        v = ca.SX.sym("v", self.n)
        u = ca.SX.sym("u", self.n_u)
        problems = []
        L = _evaluate("lagrangian", lagrangian, (q, v), (1, 1), problems)
        A = _evaluate_constraints(constraints, q, self.n, problems)
        f = _evaluate("force", force, (q, v, u), (self.n, 1), problems, default=ca.SX.zeros(self.n))
        self.names = _coordinate_names(names, self.n, problems)
        self.lagrangian = named_function("lagrangian", "L", [q, v], L, ["q", "v"], problems)
        self.constraint_matrix = named_function("constraints", "A", [q], A, ["q"], problems)
        self.force = named_function("force", "f", [q, v, u], f, ["q", "v", "u"], problems)
        if not problems:
            _check_rank(self.constraint_matrix, self.n, problems)
        if problems:
            raise ValueError("MechanicalSystem is invalid:\n  - " + "\n  - ".join(problems))
        self.m = A.shape[0]
        p = ca.gradient(L, v)
        self.momentum = ca.Function("momentum", [q, v], [p], ["q", "v"], ["p"])
        self.energy = ca.Function("energy", [q, v], [ca.dot(v, p) - L], ["q", "v"], ["E"])

    def __repr__(self):
        return f"MechanicalSystem(n={self.n}, m={self.m}, n_u={self.n_u}, names={self.names})"


def _evaluate(name, fun, args, shape, problems, default=None):
    """Call a user callable on symbols; check it returns an SX of `shape` (or its transpose)."""
    if fun is None:
        if default is None:
            problems.append(f"`{name}` is required: a callable returning a CasADi expression.")
            return ca.SX.zeros(*shape)
        return default
    if not callable(fun):
        problems.append(f"`{name}` must be callable; got {type(fun).__name__}.")
        return default if default is not None else ca.SX.zeros(*shape)
    try:
        out = ca.SX(fun(*args))
    except Exception as err:  # any failure inside user code is reported, not swallowed
        problems.append(f"`{name}` failed on symbols of the declared sizes: {type(err).__name__}: {err}")
        return default if default is not None else ca.SX.zeros(*shape)
    if out.shape == shape[::-1] and shape[0] != shape[1]:
        out = out.T
    if out.shape != shape:
        problems.append(f"`{name}` must return shape {shape}; got {out.shape}.")
        return default if default is not None else ca.SX.zeros(*shape)
    return out


def _evaluate_constraints(constraints, q, n, problems):
    """Evaluate A(q); it must have n columns (a single row may be given as a vector)."""
    if constraints is None:
        return ca.SX(0, n)
    if not callable(constraints):
        problems.append(f"`constraints` must be callable; got {type(constraints).__name__}.")
        return ca.SX(0, n)
    try:
        A = ca.SX(constraints(q))
    except Exception as err:  # reported with the other problems
        problems.append(f"`constraints` failed on a symbol q of shape ({n}, 1): {type(err).__name__}: {err}")
        return ca.SX(0, n)
    if A.shape == (n, 1) and n != 1:
        A = A.T
    if A.shape[1] != n:
        problems.append(f"`constraints` must return an (m, {n}) matrix; got {A.shape}.")
        return ca.SX(0, n)
    return A


def named_function(name, label, inputs, output, input_names, problems):
    """A Function `label` of `output` built from the user callable `name`; None and a
    problem appended to `problems` if the callable used symbols other than its arguments."""
    try:
        return ca.Function(label, inputs, [output], input_names, [label])
    except RuntimeError:
        free = [str(x) for x in ca.symvar(output) if not any(ca.depends_on(x, i) for i in inputs)]
        problems.append(f"`{name}` uses symbols that are not its arguments: {free}; build it "
                        f"from the arguments it is called with.")
        return None


def _check_rank(constraint_matrix, n, problems):
    """A problem if the rows of A(q) are dependent at random configurations (the step
    equations would then be singular)."""
    rng = np.random.default_rng(0)
    m = constraint_matrix.size1_out(0)
    ranks = [np.linalg.matrix_rank(np.array(constraint_matrix(rng.normal(size=n)))) for _ in range(3)]
    if m and max(ranks) < m:
        problems.append(f"`constraints` must have linearly independent rows: A(q) has rank "
                        f"{max(ranks)} < m = {m} at random q; drop the redundant rows.")


def _coordinate_names(names, n, problems):
    if names is None:
        return tuple(f"q{i}" for i in range(n))
    names = tuple(names)
    if len(names) != n or not all(isinstance(s, str) for s in names):
        problems.append(f"`names` must be {n} strings; got {names!r}.")
    return names
