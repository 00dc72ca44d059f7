"""Quadrature rules: how a rule turns continuous data into discrete data on one step
[t_k, t_k + h]. A rule is a value that declares its properties: the nodes of its
interpolating polynomial q(t) (the end points q_k, q_{k+1} and, between them, the stage
unknowns of the residual), its quadrature points and weights, its order and stage count.
The discrete Lagrangian, the discrete forces f_d^-/+ (as virtual work) and discrete running
costs are all the same weighted sum over the quadrature points, so adding a rule means
listing its nodes and points (docs/theory.md, "Rules").
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import _checks


@dataclass(frozen=True)
class QuadratureRule:
    """A quadrature rule on a polynomial interpolant of q over one step.

    Parameters
    ----------
    name : str
    order : int
        Global order of the resulting integrator.
    nodes : tuple of float
        Interpolation nodes c in [0, 1], first 0 and last 1: q(t_k + c h) passes through
        q_k, the stage values Q_1 ... Q_{n_stages} (unknowns of the residual) and q_{k+1}.
    points : tuple of (float, float)
        Quadrature points (c, b): the sample q(t_k + c h), q'(t_k + c h), weight b h.

    Attributes
    ----------
    n_stages : int
        Interior nodes, each an unknown configuration (n rows) of every step.

    Examples
    --------
    >>> rule = QuadratureRule("simpson", 4, (0.0, 0.5, 1.0), ((0.0, 1/6), (0.5, 2/3), (1.0, 1/6)))
    >>> rule.n_stages
    1
    """

    name: str
    order: int
    nodes: tuple = (0.0, 1.0)
    points: tuple = ()

    def __post_init__(self):
        nodes = tuple(float(c) for c in self.nodes)
        if len(nodes) < 2 or nodes[0] != 0.0 or nodes[-1] != 1.0 or np.any(np.diff(nodes) <= 0):
            raise ValueError(f"`nodes` must increase from 0 to 1; got {self.nodes!r}.")
        points = tuple((float(c), float(b)) for c, b in self.points)
        if not points or abs(sum(b for _, b in points) - 1.0) > 1e-12:
            raise ValueError(f"`points` must be (c, b) pairs with weights summing to 1; got {self.points!r}.")
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "points", points)

    @property
    def n_stages(self):
        return len(self.nodes) - 2

    def samples(self, q0, q1, s, h):
        """Quadrature points of one step: a list of (weight, q, v).

        q(c) = q0 + sum_i l_i(c) (Q_i - q0) and v(c) = sum_i l_i'(c) (Q_i - q0) / h over the
        nodes after the first (Q = stages of `s`, then q1), l_i the Lagrange basis of the
        nodes: written in increments from q0, so a linear rule's velocity is exactly
        (q1 - q0)/h. `s` holds the stage values, ``n_stages * n`` rows, stage by stage.
        """
        n = q0.shape[0]
        ends = [s[j * n:(j + 1) * n] - q0 for j in range(self.n_stages)] + [q1 - q0]
        out = []
        for c, b in self.points:
            value, slope = _lagrange_basis(self.nodes, c)
            q = q0 + _combination(value[1:], ends)
            v = _combination(slope[1:], ends) / h
            out.append((b * h, q, v))
        return out

    def __repr__(self):
        return f"QuadratureRule({self.name!r}, order={self.order}, n_stages={self.n_stages})"


def _lagrange_basis(nodes, c):
    """Values l_i(c) and derivatives l_i'(c) of the Lagrange basis on `nodes`."""
    nodes = np.asarray(nodes)
    value, slope = np.ones(len(nodes)), np.zeros(len(nodes))
    for i, ci in enumerate(nodes):
        others = np.delete(nodes, i)
        denominator = np.prod(ci - others)
        value[i] = np.prod(c - others) / denominator
        slope[i] = sum(np.prod(np.delete(c - others, j)) for j in range(len(others))) / denominator
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
        super().__init__("trapezoid", 2, (0.0, 1.0), ((0.0, 0.5), (1.0, 0.5)))

    def __repr__(self):
        return "Trapezoid()"


RULES = {rule().name: rule for rule in (Midpoint, Trapezoid)}


def as_rule(rule):
    """Return a QuadratureRule from an instance or one of the names in RULES."""
    if isinstance(rule, QuadratureRule):
        return rule
    return RULES[_checks.choice("rule", rule, tuple(RULES))]()


def quadrature(rule, integrand, q0, q1, s, h):
    """Sum of weight * integrand(q, v) over the rule's points: the step integral of it."""
    return sum(w * integrand(q, v) for w, q, v in rule.samples(q0, q1, s, h))


def virtual_work_split(rule, force, q0, q1, s, h):
    """Discrete forces (f_d^-, f_d^+, f_d^s) of a force field `force(q, v)`.

    They are the coefficients of delta q0, delta q1 and delta s in the discrete virtual
    work sum_i w_i f(q_i, v_i) . delta q_i, with the force frozen (not differentiated).
    For the midpoint rule both equal h/2 f(midpoint).
    """
    frozen = [(w * force(q, v), q) for w, q, v in rule.samples(q0, q1, s, h)]
    out = []
    for x in (q0, q1, s):
        if x.numel() == 0:
            out.append(ca.SX(0, 1))
            continue
        out.append(sum(ca.mtimes(ca.jacobian(q, x).T, fw) for fw, q in frozen))
    return tuple(out)
