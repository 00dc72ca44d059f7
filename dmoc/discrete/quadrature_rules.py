"""Discretization stage, the Lagrangian rules: `QuadratureRule`, a quadrature rule on a
polynomial interpolant of q over one step (its nodes, quadrature points and weights, order
and control nodes), with the discrete constraints (28) as Legendre moments along the
interpolant and the holonomic rows g at its nodes, and the built-in rules `Midpoint`,
`Trapezoid`, `Lobatto3` and `Lobatto4` listed in `RULES` (docs/theory.md, "Rules" and
"Stage rules"; docs/stages/discretization.md).
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np
from numpy.polynomial import legendre

from .._util import checks, typed_ops
from ..errors import InputError
from .rules import Rule, lagrange_basis, linear_combination


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
        run do not add up to an energy drift (q0 + (q1 - q0)/2 drifted 2e-10 relative over
        1e5 steps of the inclined knife edge, against 1e-12). `s` holds the stage values, ``n_stage_blocks * n`` rows, stage by
        stage. `points` defaults to the rule's quadrature points.
        """
        nodes = self.node_values(q0, q1, s)
        ends = [typed_ops.minus(Q, q0) for Q in nodes[1:]]
        out = []
        for c, b in self.points if points is None else points:
            value, slope = lagrange_basis(self.nodes, c)
            out.append((typed_ops.times(float(b), h), linear_combination(value, nodes),
                        typed_ops.divide(linear_combination(slope[1:], ends), h), c))
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
        return ca.vertcat(*[linear_combination([b * legendre.legval(2 * c - 1, np.eye(l + 1)[l])
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
