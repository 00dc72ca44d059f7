"""Discretization stage, the rule interface: how a rule turns continuous data into discrete
data on one step [t_k, t_k + h]. `Rule` is what a Discretization and the consumers read from
a rule of either family, the Lagrangian `QuadratureRule`s of
`dmoc.discrete.quadrature_rules` and the Hamiltonian rules of `dmoc.discrete.hamiltonian`:
the nodes of its interpolating polynomial q(t) (the end points q_k, q_{k+1} and, between
them, the stage unknowns of the residual), its order, stage blocks, control nodes and where
its multipliers sit. The discrete Lagrangian, the discrete forces f_d^-/+ (as virtual work)
and discrete running costs are all the same weighted sum over the quadrature points
(`quadrature`, `virtual_work`), so adding a rule means listing its nodes and points
(docs/theory.md, "Rules"; docs/stages/discretization.md, "The rule interface").
"""

from abc import ABC, abstractmethod

import casadi as ca
import numpy as np

from .._util import typed_ops
from .._util.cache import BoundedCache


class Rule(ABC):
    """The interface of every rule, Lagrangian (`QuadratureRule`) or Hamiltonian
    (`dmoc.discrete.HamiltonianRule`, the discrete Legendre transform's `LegendreRule`): what
    a Discretization and the consumers read from a rule, under one name on both families.

    Attributes
    ----------
    name : str
    order : int
        Global order of the resulting integrator.
    n_stage_blocks : int
        Stage unknowns per step in blocks of n rows (a Discretization's ``n_stages`` is
        ``n_stage_blocks * n``).
    interpolant : QuadratureRule
        The rule whose interpolant through q_k, the configurations among the stages and
        q_{k+1} is q(t) on the step: the discrete constraints omega_d (28), the midpoint
        state, the step energy of a Lagrangian system and the running cost are taken on it.
        A Lagrangian rule is its own; the Hamiltonian rules take the chord (`Midpoint`).
    stage_nodes : tuple of float
        Step times c of the configurations among the stages, Q_j = q(t_k + c_j h) on the
        interpolant, the last ``len(stage_nodes)`` blocks of s (`stage_configurations`);
        ``()`` when the stages hold none.
    control_nodes : tuple of float
        Step times c of the step's control values u_{k,j} (n_u each); the control between
        them is their Lagrange interpolant (`control_at`). ``(0.5,)``: one control held
        over the step.
    has_interior_multipliers : bool
        Whether d'Alembert multipliers (m rows each) sit at the stage nodes besides the
        formulation's end node: True for a Lagrangian rule with interior nodes, False for
        the Hamiltonian forms (38)/(42), whose one multiplier sits at the end node.
    n_multiplier_nodes : int
        Nodes that carry a multiplier: 1 + ``len(stage_nodes)`` with interior multipliers,
        else 1 (a Discretization's ``n_multipliers`` is ``n_multiplier_nodes * m``).
    """

    @property
    @abstractmethod
    def n_stage_blocks(self):
        """Stage unknowns per step, in blocks of n rows."""

    @property
    @abstractmethod
    def interpolant(self):
        """The QuadratureRule whose interpolant is q(t) on the step."""

    @property
    @abstractmethod
    def has_interior_multipliers(self):
        """Whether multipliers sit at the stage nodes too."""

    @abstractmethod
    def stage_guess(self, q, p):
        """Stage values for an initial guess from knot values q, p (N+1, n), shape
        (N, n_stage_blocks * n)."""

    @property
    def stage_nodes(self):
        return self.interpolant.nodes[1:-1]

    @property
    def n_multiplier_nodes(self):
        return 1 + len(self.stage_nodes) if self.has_interior_multipliers else 1

    def stage_configurations(self, s, n):
        """The rows of the stage column `s` that are the configurations at `stage_nodes`
        (n rows each, node by node): its last ``len(stage_nodes) * n`` rows."""
        k = len(self.stage_nodes) * n
        return s if k == s.numel() else s[s.numel() - k:]

    def control_at(self, u, c):
        """The control at step time c from the step's control values `u`
        (``len(control_nodes) * n_u`` rows, node by node): their Lagrange interpolant (the
        value itself for one control node)."""
        k = len(self.control_nodes)
        n_u = u.shape[0] // k
        values = [u[j * n_u:(j + 1) * n_u] for j in range(k)]
        return linear_combination(lagrange_basis(self.control_nodes, c)[0], values) if n_u else u

    def chord_stages(self, q):
        """The stage configurations on the chord of each step from knot values q (N+1, n):
        q_k + c (q_{k+1} - q_k) at the stage nodes, shape (N, len(stage_nodes) * n)."""
        chords = [q[:-1] + c * (q[1:] - q[:-1]) for c in self.stage_nodes]
        return np.hstack(chords) if chords else np.zeros((q.shape[0] - 1, 0))


_BASES = BoundedCache(256, "lagrange_bases")     # keyed by (nodes, c): `lagrange_basis` at a number c


def lagrange_basis(nodes, c):
    """Values l_i(c) and derivatives l_i'(c) of the Lagrange basis on `nodes`, each of
    shape c.shape + (len(nodes),) (c a number or an array of step times in [0, 1]). For a
    number c the pair is computed once per (nodes, c) and shared, read-only (a rule's
    quadrature asks for the same points at every build)."""
    if np.ndim(c) == 0:
        nodes = tuple(float(ci) for ci in np.ravel(nodes))
        return _BASES.get((nodes, float(c)), lambda: _read_only(*_basis(nodes, c)))
    return _basis(nodes, c)


def _read_only(*arrays):
    """`arrays`, flagged read-only (shared by `_BASES`)."""
    for a in arrays:
        a.flags.writeable = False
    return arrays


def _basis(nodes, c):
    """`lagrange_basis`, computed."""
    nodes, c = np.asarray(nodes, dtype=float), np.asarray(c, dtype=float)
    value = np.ones(c.shape + (len(nodes),))
    slope = np.zeros_like(value)
    for i, ci in enumerate(nodes):
        others = np.delete(nodes, i)
        denominator = np.prod(ci - others)
        factors = c[..., None] - others
        value[..., i] = np.prod(factors, axis=-1) / denominator
        slope[..., i] = sum(np.prod(np.delete(factors, j, axis=-1), axis=-1)
                            for j in range(len(others))) / denominator
    return value, slope


def linear_combination(coefficients, terms):
    """sum_i a_i x_i with zero coefficients dropped and unit ones not multiplied (exact
    expressions for linear interpolation: q0 + (q1 - q0), not q0 + 1.0 * (q1 - q0)). A
    NumPy coefficient enters as the Python float of the same value (NumPy's product with
    an SX first tries an array conversion: slower, the same expression)."""
    kept = [x if a == 1.0 else typed_ops.times(float(a), x) for a, x in zip(coefficients, terms) if a != 0.0]
    return typed_ops.total(kept) if kept else ca.SX.zeros(terms[0].shape)


def quadrature(rule, integrand, q0, q1, s, u, h):
    """Sum of weight * integrand(q, v, u, c) over the quadrature points of `rule`'s
    interpolant (any `Rule`), u the control there, c the point's fraction of the step: the
    step integral of it on q(t)."""
    shape = rule.interpolant
    points = shape.samples(q0, q1, rule.stage_configurations(s, q0.shape[0]), h)
    return typed_ops.total(typed_ops.times(w, integrand(q, v, rule.control_at(u, c), c))
                           for w, q, v, c in points)


def virtual_work(rule, force, samples, u, variables):
    """Discrete forces of a force field `force(q, y, u)` (y the velocity or the momentum
    of the sample): the coefficients of delta x, for each x of `variables`, in the discrete
    virtual work sum_i w_i f(q_i, y_i, u(c_i)) . delta q_i over `samples` (w_i, q_i, y_i,
    c_i), with the force frozen (not differentiated) and u(c_i) the control of `rule` at
    the sample (`Rule.control_at`).

    With the samples of a QuadratureRule and variables (q0, q1, s) these are f_d^-, f_d^+
    and f_d^s (midpoint rule: both h/2 f(midpoint)); with a Hamiltonian rule's and (end, s),
    the forces of H_d+ or H_d-.
    """
    frozen = [(typed_ops.times(w, force(q, y, rule.control_at(u, c))), q) for w, q, y, c in samples]
    return tuple(typed_ops.total(ca.mtimes(ca.jacobian(q, x).T, fw) for fw, q in frozen) if x.numel()
                 else ca.SX(0, 1) for x in variables)
