"""Quadrature rules that turn continuous data into discrete data on one step [t_k, t_k + h].

A rule samples the curve q(t) on the step at quadrature points; the discrete Lagrangian,
the discrete forces f_d^-/+ (as virtual work) and discrete running costs are all weighted
sums over those points, so adding a rule means listing its points. Rules with internal
stages declare ``n_stages`` extra configuration unknowns per step (none yet).
"""

import casadi as ca

from .. import _checks


class QuadratureRule:
    """A quadrature rule on linear interpolation between q0 and q1.

    Subclasses set ``name``, ``order`` (global order of the resulting integrator) and
    ``points``: pairs (c, b) meaning the sample q0 + c (q1 - q0) with weight b h, velocity
    (q1 - q0)/h at every point.
    """

    name = None
    order = None
    points = ()
    n_stages = 0

    def samples(self, q0, q1, s, h):
        """Quadrature points of one step: a list of (weight, q, v).

        `s` holds the stage unknowns (``n_stages * n`` rows, empty here).
        """
        v = (q1 - q0) / h
        return [(b * h, q0 + c * (q1 - q0), v) for c, b in self.points]

    def __repr__(self):
        return f"{type(self).__name__}()"


class Midpoint(QuadratureRule):
    """Midpoint rule: L_d = h L((q0 + q1)/2, (q1 - q0)/h); second order.

    >>> Midpoint().order
    2
    """

    name = "midpoint"
    order = 2
    points = ((0.5, 1.0),)


class Trapezoid(QuadratureRule):
    """Trapezoidal rule: L_d = h/2 [L(q0, v) + L(q1, v)], v = (q1 - q0)/h; second order.

    For L = v^T M v/2 - V(q) the resulting integrator is Stormer-Verlet.

    >>> Trapezoid().order
    2
    """

    name = "trapezoid"
    order = 2
    points = ((0.0, 0.5), (1.0, 0.5))


RULES = {rule.name: rule for rule in (Midpoint, Trapezoid)}


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
