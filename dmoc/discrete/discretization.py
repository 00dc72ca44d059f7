"""Discretization, the second stage of the pipeline: from a MechanicalSystem and a step h
to the discrete Lagrangian L_d, the discrete constraints omega_d of (28) (Cortes-Martinez,
midpoint retraction) and the discrete forces f_d^-/+, each a named CasADi Function whose
last input is the step h (so that a free final time can make h a decision variable).
"""

import casadi as ca

from .. import _checks
from .._cache import BoundedCache
from ..system import MechanicalSystem
from .degenerate import check_one_step_map
from .rules import as_rule, quadrature, virtual_work_split


class Discretization:
    """Discrete data of a mechanical system on a uniform grid of step `h`.

    Build it with `discretize`. With z = (q0, q1, s, ...) for one step [t_k, t_k + h]:

    Attributes
    ----------
    system : MechanicalSystem
    h : float
        The step.
    rule : QuadratureRule
        The quadrature rule; ``rule.order`` is the order of the resulting integrator.
    n_stages : int
        Stage unknowns per step (``rule.n_stages * n`` rows of s; 0 for stage-free rules).
    discrete_lagrangian : casadi.Function
        ``L_d(q0, q1, s, h)``, scalar.
    discrete_constraint : casadi.Function
        ``omega_d(q0, q1, h) = A((q0 + q1)/2) (q1 - q0)/h``, shape (m,): eq. (28) with the
        midpoint retraction; Delta_Q^d is its zero set.
    discrete_force : casadi.Function
        ``f_d(q0, q1, s, u, h) -> (f_minus, f_plus, f_stage)``: the left and right discrete
        forces (n,) and the force on the stages.
    key : tuple
        ``(system.key, rule)``: what the step residual and the compiled steps depend on.
        Every Function above takes h as an input, so discretizations that differ only in
        h share them.
    """

    def __init__(self, system, h, rule="midpoint"):
        if not isinstance(system, MechanicalSystem):
            raise TypeError(f"`system` must be a MechanicalSystem; got {type(system).__name__}.")
        self.system = system
        self.h = _checks.positive_float("h", h)
        self.rule = rule = as_rule(rule)
        self.key = (system.key, rule)
        self.n_stages = rule.n_stages * system.n
        self.discrete_lagrangian, self.discrete_constraint, self.discrete_force = \
            _DISCRETE_DATA.get(self.key, lambda: _discrete_data(system, rule))
        check_one_step_map(self)

    def discrete_cost(self, running_cost):
        """The step integral C_d(q0, q1, s, u, h) of ``running_cost(q, v, u)`` by this rule."""
        n, n_u = self.system.n, self.system.n_u
        q0, q1 = ca.SX.sym("q0", n), ca.SX.sym("q1", n)
        s, u, hs = ca.SX.sym("s", self.n_stages), ca.SX.sym("u", n_u), ca.SX.sym("h")
        C_d = quadrature(self.rule, lambda q, v: running_cost(q, v, u), q0, q1, s, hs)
        return ca.Function("C_d", [q0, q1, s, u, hs], [C_d], ["q0", "q1", "s", "u", "h"], ["C_d"])

    def __repr__(self):
        return f"Discretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


_DISCRETE_DATA = BoundedCache(32)


def _discrete_data(system, rule):
    """(L_d, omega_d, f_d) of `system` by `rule`, h an input: built once per system key
    and rule, shared by discretizations at every h."""
    n, n_u, ns = system.n, system.n_u, rule.n_stages * system.n
    q0, q1 = ca.SX.sym("q0", n), ca.SX.sym("q1", n)
    s, u, hs = ca.SX.sym("s", ns), ca.SX.sym("u", n_u), ca.SX.sym("h")
    L_d = quadrature(rule, lambda q, v: system.lagrangian(q, v), q0, q1, s, hs)
    omega_d = ca.mtimes(system.constraint_matrix((q0 + q1) / 2), (q1 - q0) / hs)
    forces = virtual_work_split(rule, lambda q, v: system.force(q, v, u), q0, q1, s, hs)
    return (ca.Function("L_d", [q0, q1, s, hs], [L_d], ["q0", "q1", "s", "h"], ["L_d"]),
            ca.Function("omega_d", [q0, q1, hs], [omega_d], ["q0", "q1", "h"], ["omega_d"]),
            ca.Function("f_d", [q0, q1, s, u, hs], list(forces),
                        ["q0", "q1", "s", "u", "h"], ["f_minus", "f_plus", "f_stage"]))


def discretize(system, h, rule="midpoint"):
    """Discrete Lagrangian, constraints (28) and forces of `system` on steps of size `h`.

    Parameters
    ----------
    system : MechanicalSystem
    h : float
        Step size, > 0.
    rule : str or QuadratureRule
        ``"midpoint"`` (default) or ``"trapezoid"``, or a rule instance.

    Returns
    -------
    Discretization

    Examples
    --------
    >>> import casadi as ca
    >>> from dmoc import MechanicalSystem
    >>> s = MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) - 0.5 * ca.dot(q, q), 1)
    >>> d = discretize(s, 0.1)
    >>> round(float(d.discrete_lagrangian(0.0, 0.2, [], 0.1)), 6)  # 0.1 * (2 - 0.005)
    0.1995
    """
    return Discretization(system, h, rule)
