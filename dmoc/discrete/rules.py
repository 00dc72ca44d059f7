"""Quadrature rules: how a rule turns continuous data into discrete data on one step
[t_k, t_k + h]. A rule is a value that declares its properties (`Rule`, the interface the
Lagrangian rules here and the Hamiltonian rules of `dmoc.discrete.hamiltonian` share): the
nodes of its interpolating polynomial q(t) (the end points q_k, q_{k+1} and, between them,
the stage unknowns of the residual), its quadrature points and weights, its order, stage
blocks, control nodes and where its multipliers sit. The discrete Lagrangian, the discrete
forces f_d^-/+ (as virtual work) and discrete running costs are all the same weighted sum
over the quadrature points, so adding a rule means listing its nodes and points
(docs/theory.md, "Rules"; docs/stages/discretization.md, "The rule interface").
"""

from abc import ABC, abstractmethod
from dataclasses import dataclass

import casadi as ca
import numpy as np
from numpy.polynomial import legendre

from .._util import checks
from ..errors import InputError


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
        return _combination(lagrange_basis(self.control_nodes, c)[0], values) if n_u else u

    def chord_stages(self, q):
        """The stage configurations on the chord of each step from knot values q (N+1, n):
        q_k + c (q_{k+1} - q_k) at the stage nodes, shape (N, len(stage_nodes) * n)."""
        chords = [q[:-1] + c * (q[1:] - q[:-1]) for c in self.stage_nodes]
        return np.hstack(chords) if chords else np.zeros((q.shape[0] - 1, 0))


@dataclass(frozen=True)
class QuadratureRule(Rule):
    """A quadrature rule on a polynomial interpolant of q over one step: the Lagrangian
    family of `Rule`.

    Parameters
    ----------
    name : str
    order : int
        Global order of the resulting integrator (positions; see docs/theory.md, "Rules").
    nodes : tuple of float
        Interpolation nodes c in [0, 1], first 0 and last 1: q(t_k + c h) passes through
        q_k, the stage values Q_1 ... Q_{n_stage_blocks} (unknowns of the residual) and q_{k+1}.
    points : tuple of (float, float)
        Quadrature points (c, b): the sample q(t_k + c h), q'(t_k + c h), weight b h.
    control_nodes : tuple of float
        Times c of the step's control values u_{k,j} (n_u each); the control at a
        quadrature point is their Lagrange interpolant. ``(0.5,)``: one control held over
        the step.
    constraint_points : tuple of (float, float), optional
        Quadrature of the discrete constraints (default `points`): the rows
        sum_i b_i P_l(2 c_i - 1) A(q(c_i)) q'(c_i), l = 0 ... len(nodes) - 2, P_l the
        Legendre polynomials. With the single point (0.5, 1) this is (28) with the
        midpoint retraction.
    degenerate_order : int, optional
        The global order the rule keeps on a degenerate Lagrangian (d^2L/dv^2 singular,
        e.g. linear in v) when it is lower than `order`; None (default): `order` is kept.
        A Discretization reports the order that applies (`Discretization.order`;
        docs/degenerate.md, "Order of the stage rules").

    Attributes
    ----------
    n_stage_blocks : int
        Interior nodes, each an unknown configuration (n rows) of every step.
    stage_nodes : tuple of float
        The interior nodes.
    has_interior_multipliers : bool
        True when there are interior nodes: each carries a d'Alembert multiplier (m rows).
    n_multiplier_nodes : int
        Nodes that carry a d'Alembert multiplier (m rows each) in every step: the
        formulation's end node and the interior nodes; as many as constraint rows per
        constraint, so every step is square.
    interpolant : QuadratureRule
        The rule itself.

    Examples
    --------
    >>> rule = QuadratureRule("simpson", 4, (0.0, 0.5, 1.0), ((0.0, 1/6), (0.5, 2/3), (1.0, 1/6)))
    >>> rule.n_stage_blocks, rule.n_multiplier_nodes, rule.control_at(ca.DM([2.0]), 0.25)
    (1, 2, DM(2))
    """

    name: str
    order: int
    nodes: tuple = (0.0, 1.0)
    points: tuple = ()
    control_nodes: tuple = (0.5,)
    constraint_points: tuple = None
    degenerate_order: int = None

    def __post_init__(self):
        nodes = _increasing("nodes", self.nodes)
        if len(nodes) < 2 or nodes[0] != 0.0 or nodes[-1] != 1.0:
            raise InputError(f"`nodes` must increase from 0 to 1; got {self.nodes!r}.")
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "control_nodes", _increasing("control_nodes", self.control_nodes))
        object.__setattr__(self, "points", _quadrature_points("points", self.points))
        object.__setattr__(self, "constraint_points", _quadrature_points(
            "constraint_points", self.points if self.constraint_points is None else self.constraint_points))
        if self.degenerate_order is not None and checks.positive_int(
                "degenerate_order", self.degenerate_order) > self.order:
            raise InputError(f"`degenerate_order` must not exceed `order` ({self.order}): it is the "
                             f"lower order kept on a degenerate Lagrangian; got {self.degenerate_order}.")

    @property
    def n_stage_blocks(self):
        return len(self.nodes) - 2

    @property
    def interpolant(self):
        return self

    @property
    def has_interior_multipliers(self):
        return len(self.nodes) > 2

    def node_values(self, q0, q1, s):
        """[q0, Q_1, ..., Q_{n_stage_blocks}, q1]: the configurations at the nodes."""
        n = q0.shape[0]
        return [q0] + [s[j * n:(j + 1) * n] for j in range(self.n_stage_blocks)] + [q1]

    def samples(self, q0, q1, s, h, points=None):
        """Quadrature points of one step: a list of (weight, q, v, c).

        q(c) = sum_i l_i(c) Q_i over all nodes and v(c) = sum_i l_i'(c) (Q_i - q0) / h over
        the nodes after the first (Q = q0, the stages of `s`, q1), l_i the Lagrange basis
        of the nodes. The velocity is written in increments from q0 (sum_i l_i' = 0), so a
        linear rule's is exactly (q1 - q0)/h; the position keeps the form symmetric in the
        nodes ((q0 + q1)/2 for the midpoint, not q0 + (q1 - q0)/2), which keeps the
        rounding of a symmetric rule time-reversible, so that the rounding errors of a long
        run do not add up to an energy drift (docs/performance.md, "Measured and not
        adopted"). `s` holds the stage values, ``n_stage_blocks * n`` rows, stage by
        stage. `points` defaults to the rule's quadrature points.
        """
        nodes = self.node_values(q0, q1, s)
        ends = [Q - q0 for Q in nodes[1:]]
        out = []
        for c, b in self.points if points is None else points:
            value, slope = lagrange_basis(self.nodes, c)
            out.append((b * h, _combination(value, nodes), _combination(slope[1:], ends) / h, c))
        return out

    def stage_guess(self, q, p):
        """Stage values on the chord of each step for an initial guess from knot values q
        (N+1, n): q_k + c (q_{k+1} - q_k) at the interior nodes, shape
        (N, n_stage_blocks * n)."""
        return self.chord_stages(q)

    def discrete_constraint(self, A, q0, q1, s, h):
        """The discrete constraint rows of one step, (n_multiplier_nodes * m,): the Legendre
        moments sum_i b_i P_l(2 c_i - 1) A(q(c_i)) q'(c_i), l = 0 ... n_multiplier_nodes - 1,
        over `constraint_points` (docs/theory.md, "Rules")."""
        Av = [ca.mtimes(A(q), v) for _, q, v, _ in self.samples(q0, q1, s, h, self.constraint_points)]
        moments = range(self.n_multiplier_nodes)
        return ca.vertcat(*[_combination([b * legendre.legval(2 * c - 1, np.eye(l + 1)[l])
                                          for c, b in self.constraint_points], Av) for l in moments])

    def holonomic_constraint(self, g, q0, q1, s):
        """The holonomic constraint rows of one step, (n_multiplier_nodes * k,): g at every
        node after the first, [g(Q_1), ..., g(Q_{n_stage_blocks}), g(q1)] (g(q0) is the previous
        step's, or the initial data's). One set of k rows per multiplier node, so with the
        multipliers on dg/dq at those nodes every step stays square."""
        return ca.vertcat(*[g(Q) for Q in self.node_values(q0, q1, s)[1:]])

    def __repr__(self):
        return f"QuadratureRule({self.name!r}, order={self.order}, n_stage_blocks={self.n_stage_blocks})"


def _increasing(name, values):
    values = tuple(float(c) for c in values)
    if not values or np.any(np.diff(values) <= 0) or values[0] < 0 or values[-1] > 1:
        raise InputError(f"`{name}` must increase within [0, 1]; got {values!r}.")
    return values


def _quadrature_points(name, points):
    points = tuple((float(c), float(b)) for c, b in points)
    if not points or abs(sum(b for _, b in points) - 1.0) > 1e-12:
        raise InputError(f"`{name}` must be (c, b) pairs with weights summing to 1; got {points!r}.")
    return points


def lagrange_basis(nodes, c):
    """Values l_i(c) and derivatives l_i'(c) of the Lagrange basis on `nodes`, each of
    shape c.shape + (len(nodes),) (c a number or an array of step times in [0, 1])."""
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


def _combination(coefficients, terms):
    """sum_i a_i x_i with zero coefficients dropped and unit ones not multiplied (exact
    expressions for linear interpolation: q0 + (q1 - q0), not q0 + 1.0 * (q1 - q0))."""
    total = 0
    for a, x in zip(coefficients, terms):
        if a != 0.0:
            total = total + (x if a == 1.0 else a * x)
    return total if not isinstance(total, int) else ca.SX.zeros(terms[0].shape)


class Midpoint(QuadratureRule):
    """Midpoint rule: L_d = h L((q0 + q1)/2, (q1 - q0)/h); second order.

    >>> Midpoint().order
    2
    """

    def __init__(self):
        super().__init__("midpoint", 2, (0.0, 1.0), ((0.5, 1.0),))

    def __repr__(self):
        return "Midpoint()"


class Trapezoid(QuadratureRule):
    """Trapezoidal rule: L_d = h/2 [L(q0, v) + L(q1, v)], v = (q1 - q0)/h; second order.

    For L = v^T M v/2 - V(q) the resulting integrator is Stormer-Verlet.

    >>> Trapezoid().order
    2
    """

    def __init__(self):
        super().__init__("trapezoid", 2, (0.0, 1.0), ((0.0, 0.5), (1.0, 0.5)),
                         constraint_points=((0.5, 1.0),))

    def __repr__(self):
        return "Trapezoid()"


SQRT5 = np.sqrt(5.0)


class Lobatto3(QuadratureRule):
    """Galerkin rule on the Lobatto nodes (0, 1/2, 1): the variational Lobatto IIIA-IIIB
    pair, order 4; one stage unknown per step, controls at the three nodes.

    L_d = h/6 [L(q0, V_0) + 4 L(Q, V_1/2) + L(q1, V_1)] on the quadratic through q0, Q, q1;
    the discrete constraints are its two Legendre moments (docs/theory.md, "Rules").
    On a degenerate Lagrangian (linear in v) it keeps order 2 (`degenerate_order`).

    >>> Lobatto3().order, Lobatto3().n_stage_blocks, Lobatto3().degenerate_order
    (4, 1, 2)
    """

    def __init__(self):
        nodes = (0.0, 0.5, 1.0)
        super().__init__("lobatto3", 4, nodes, tuple(zip(nodes, (1 / 6, 2 / 3, 1 / 6))),
                         control_nodes=nodes, degenerate_order=2)

    def __repr__(self):
        return "Lobatto3()"


class Lobatto4(QuadratureRule):
    """Galerkin rule on the four Lobatto nodes 0, (5 -+ sqrt 5)/10, 1 (weights 1/12, 5/12,
    5/12, 1/12): order 6 in positions, also with constraints; two stage unknowns per step.
    On a degenerate Lagrangian (linear in v) it keeps order 4 (`degenerate_order`).

    >>> Lobatto4().order, Lobatto4().n_multiplier_nodes
    (6, 3)
    """

    def __init__(self):
        nodes = (0.0, (5 - SQRT5) / 10, (5 + SQRT5) / 10, 1.0)
        super().__init__("lobatto4", 6, nodes, tuple(zip(nodes, (1 / 12, 5 / 12, 5 / 12, 1 / 12))),
                         control_nodes=nodes, degenerate_order=4)

    def __repr__(self):
        return "Lobatto4()"


RULES = {rule().name: rule for rule in (Midpoint, Trapezoid, Lobatto3, Lobatto4)}


def as_rule(rule):
    """Return a QuadratureRule from an instance or one of the names in RULES."""
    if isinstance(rule, QuadratureRule):
        return rule
    return RULES[checks.choice("rule", rule, tuple(RULES))]()


def quadrature(rule, integrand, q0, q1, s, u, h):
    """Sum of weight * integrand(q, v, u) over the quadrature points of `rule`'s
    interpolant (any `Rule`), u the control there: the step integral of it on q(t)."""
    shape = rule.interpolant
    points = shape.samples(q0, q1, rule.stage_configurations(s, q0.shape[0]), h)
    return sum(w * integrand(q, v, rule.control_at(u, c)) for w, q, v, c in points)


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
    frozen = [(w * force(q, y, rule.control_at(u, c)), q) for w, q, y, c in samples]
    return tuple(sum(ca.mtimes(ca.jacobian(q, x).T, fw) for fw, q in frozen) if x.numel()
                 else ca.SX(0, 1) for x in variables)
