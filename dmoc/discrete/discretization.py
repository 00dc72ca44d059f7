"""Discretization, the second stage of the pipeline: from a MechanicalSystem and a step h
to the discrete Lagrangian L_d, the discrete constraints omega_d of (28) (Cortes-Martinez,
midpoint retraction, or their stage-rule extension) and the discrete forces f_d^-/+, each a
named CasADi Function whose last input is the step h (so that one Function serves every h
and a free final time can make h a decision variable).
"""

import copy

import casadi as ca

from .._util import checks
from .._util.cache import BoundedCache
from .._util.layout import step_symbols
from ..errors import InputTypeError
from ..mechanics.system import HamiltonianSystem, MechanicalSystem
from .degenerate import declared_order
from .quadrature_rules import as_rule
from .rules import quadrature, virtual_work


class Discretization:
    """Discrete data of a mechanical system on a uniform grid of step `h`.

    Build it with `discretize`. With z = (q0, q1, s, ...) for one step [t_k, t_k + h]:

    Attributes
    ----------
    system : MechanicalSystem
    h : float
        The step.
    rule : QuadratureRule
        The quadrature rule (a `dmoc.discrete.Rule`). The sizes below are derived from it
        here, for both families.
    order : int
        The global order of the integrator on this system: ``rule.order``, except for a
        stage rule on a degenerate Lagrangian (d^2L/dv^2 singular), where it is the lower
        ``rule.degenerate_order`` (lobatto3: 2, lobatto4: 4; docs/degenerate.md, "Order of
        the stage rules"), and `discretize` warns.
    n_stages : int
        Stage unknowns per step (``rule.n_stage_blocks * n`` rows of s; 0 for stage-free
        rules).
    n_multipliers : int
        d'Alembert multipliers per step (``rule.n_multiplier_nodes * m`` rows of lam: the
        formulation's end node, then the interior nodes; m counts the nonholonomic and the
        holonomic one-forms, so k holonomic constraints add k per node).
    n_controls : int
        Control values per step (``len(rule.control_nodes) * n_u`` rows of u, node by node).
    discrete_lagrangian : casadi.Function
        ``L_d(q0, q1, s, h)``, scalar.
    discrete_constraint : casadi.Function
        ``omega_d(q0, q1, s, h)``, shape (n_multipliers,): first the nonholonomic rows, for
        stage-free rules eq. (28) with the midpoint retraction, A_nh((q0 + q1)/2) (q1 - q0)/h,
        for stage rules the Legendre moments of A_nh(q) q' along the interpolant
        (`QuadratureRule.discrete_constraint`); then the holonomic rows g at every node
        after q0 (`QuadratureRule.holonomic_constraint`; g(q1) for stage-free rules).
        Delta_Q^d is its zero set.
    discrete_force : casadi.Function
        ``f_d(q0, q1, s, u, h) -> (f_minus, f_plus, f_stage)``: the left and right discrete
        forces (n,) and the force on the stages (n_stages,).
    midpoint_state : casadi.Function
        ``(q0, q1, s, h) -> (q, v)``: the interpolant and its velocity at the middle of the
        step (for linear rules (q0 + q1)/2 and (q1 - q0)/h).
    step_energy : casadi.Function
        ``(q0, p0, q1, p1, s, h) -> E`` (p unused): the energy v . dL/dv - L averaged over the step by the
        rule's quadrature, sum_i b_i E(q(c_i), q'(c_i)); for the midpoint rule E at the
        midpoint. It needs no Legendre transform. This and `midpoint_state` are read by
        diagnostics, not by a solve: built on first use.
    family : str
        ``"lagrangian"``: the principle differentiates the sums (46)/(47) of L_d, and
        `variant` names the forms (37)/(41) (a HamiltonianDiscretization says
        ``"hamiltonian"``: (39)/(43) from (48)/(49)).
    key : tuple
        ``(system.key, rule)``: what the step residual and the compiled steps depend on.
        Every Function above takes h as an input, so discretizations that differ only in
        h share them.
    """

    family = "lagrangian"       # the forms (37)/(41) of the sums (46)/(47)
    system_type = MechanicalSystem
    system_described = "a MechanicalSystem or a HamiltonianSystem"
    function_names = ("discrete_lagrangian", "discrete_constraint", "discrete_force")
    # read by diagnostics, not by a solve or its verdict: built on first use (`_state`)
    midpoint_state = property(lambda self: self._state("midpoint_state"),
                              doc="``(q0, q1, s, h) -> (q, v)``, built on first use.")
    step_energy = property(lambda self: self._state("step_energy"),
                           doc="``(q0, p0, q1, p1, s, h) -> E``, built on first use.")

    def __init__(self, system, h, rule="midpoint"):
        checks.instance("system", system, self.system_type, self.system_described)
        self.system = system
        self.h = checks.step_size("h", h)
        self.rule = rule = self._as_rule(rule)
        self.key = (system.key, rule)
        self.order = self._declared_order()
        self.n_stages = rule.n_stage_blocks * system.n
        self.n_multipliers = rule.n_multiplier_nodes * system.m
        self.n_controls = len(rule.control_nodes) * system.n_u
        functions = _DISCRETE_DATA.get(self.key, self._functions)
        for name in self.function_names:
            setattr(self, name, functions[name])

    def _as_rule(self, rule):
        """`rule` as a rule of this family (an instance, or a name checked against the
        family's list)."""
        return as_rule(rule)

    def _declared_order(self):
        """The order of the rule on this system (`dmoc.discrete.degenerate`)."""
        return declared_order(self.system, self.rule)

    def _functions(self):
        """{name: Function} of `function_names`, h an input: built once per system key and
        rule, shared by discretizations at every h."""
        system, rule = self.system, self.rule
        x = step_symbols(system.n, self.n_stages, self.n_controls)
        q0, q1, s, u, h = x["q0"], x["q1"], x["s"], x["u"], x["h"]
        L_d = quadrature(rule, lambda q, v, *_: system.lagrangian(q, v), q0, q1, s, ca.SX(0, 1), h)
        forces = virtual_work(rule, system.force, rule.samples(q0, q1, s, h), u, (q0, q1, s))
        return {"discrete_lagrangian": ca.Function("L_d", [q0, q1, s, h], [L_d],
                                                   ["q0", "q1", "s", "h"], ["L_d"]),
                "discrete_force": ca.Function("f_d", [q0, q1, s, u, h], list(forces),
                                              ["q0", "q1", "s", "u", "h"],
                                              ["f_minus", "f_plus", "f_stage"]),
                "discrete_constraint": constraint_function(system, rule, x)}

    def _state(self, name):
        """`name` of `state_functions` ("midpoint_state" or "step_energy"), built once per
        system key and rule on first use, as the Functions of `_functions`."""
        return _DISCRETE_DATA.get((self.key, "state"), lambda: state_functions(
            self.system, self.rule, step_symbols(self.system.n, self.n_stages, self.n_controls)))[name]

    def with_step(self, h):
        """The same discretization at the step `h` (sharing every Function: h is an input),
        e.g. to replay a free-time optimum."""
        other = copy.copy(self)
        other.h = checks.step_size("h", h)
        return other

    def discrete_cost(self, running_cost, parameters_at=None):
        """The step integral C_d(q0, q1, s, u, h, w) of ``running_cost(q, v, u[, w])`` (a
        callable or a Function; `running_integrand`) by the quadrature of the rule's
        interpolant (`Rule.interpolant`; the chord's midpoint for a HamiltonianRule), u the
        control interpolated at each quadrature point, w the problem's parameters
        (`dmoc.optimal_control.statement.parameters`; empty when the cost takes none).
        With `parameters_at`, a Function ``(w, c, h) -> w_c``, w is the step's vector of
        parameters and the cost reads w_c at the fraction c of the step of each point
        (values that vary along the horizon, the time)."""
        running_cost = running_integrand(self.system, running_cost)
        x = step_symbols(self.system.n, self.n_stages, self.n_controls)
        q0, q1, s, u, h = x["q0"], x["q1"], x["s"], x["u"], x["h"]
        w = ca.SX.sym("w", running_cost.size1_in(3) if parameters_at is None else parameters_at.size1_in(0))

        def integrand(q, v, uc, c):
            return running_cost(q, v, uc, w if parameters_at is None else parameters_at(w, c, h))
        C_d = quadrature(self.rule, integrand, q0, q1, s, u, h)
        return ca.Function("C_d", [q0, q1, s, u, h, w], [C_d], ["q0", "q1", "s", "u", "h", "w"], ["C_d"])

    def __repr__(self):
        return f"Discretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


_DISCRETE_DATA = BoundedCache(32, "discrete_data")


def running_integrand(system, running_cost):
    """`running_cost` as the Function ``(q, v, u, w) -> scalar``: a Function of those four
    inputs as it is; a Function or callable of (q, v, u) with an empty w."""
    if isinstance(running_cost, ca.Function) and running_cost.n_in() == 4:
        return running_cost
    if not callable(running_cost):
        raise InputTypeError(f"`running_cost` must be a callable (q, v, u) or a casadi.Function of "
                             f"(q, v, u[, w]); got {type(running_cost).__name__}.")
    q, v, u = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n), ca.SX.sym("u", system.n_u)
    w = ca.SX.sym("w", 0)
    return ca.Function("running_cost", [q, v, u, w], [running_cost(q, v, u)], ["q", "v", "u", "w"],
                       ["running_cost"])


def constraint_function(system, rule, x):
    """omega_d of a discretization of `system` by `rule` (either family), the Function
    "omega_d" of the step symbols `x` (`step_symbols`), taken on the rule's interpolant
    through q0, the stage configurations and q1 (`Rule.interpolant`,
    `Rule.stage_configurations`): the nonholonomic rows (28) (midpoint retraction on the
    chord, Legendre moments on a stage rule's polynomial) and the holonomic rows g at its
    nodes after q0."""
    q0, q1, s, h = x["q0"], x["q1"], x["s"], x["h"]
    shape, sigma = rule.interpolant, rule.stage_configurations(s, system.n)
    omega_d = ca.vertcat(shape.discrete_constraint(system.nonholonomic_matrix, q0, q1, sigma, h),
                         shape.holonomic_constraint(system.holonomic, q0, q1, sigma))
    return ca.Function("omega_d", [q0, q1, s, h], [omega_d], ["q0", "q1", "s", "h"], ["omega_d"])


def state_functions(system, rule, x):
    """{"midpoint_state", "step_energy"} of a discretization of `system` by `rule` (either
    family), named Functions of the step symbols `x` (`step_symbols`).

    The midpoint state is taken on the rule's interpolant, as omega_d
    (`constraint_function`). The step energy of a MechanicalSystem is the quadrature of
    E(q, q') = q' . dL/dv - L along it divided by h (no Legendre transform needed); that of
    a HamiltonianSystem (H(q0, p0) + H(q1, p1))/2.
    """
    q0, q1, s, h = x["q0"], x["q1"], x["s"], x["h"]
    shape, sigma = rule.interpolant, rule.stage_configurations(s, system.n)
    (_, q_mid, v_mid, _), = shape.samples(q0, q1, sigma, h, ((0.5, 1.0),))
    if isinstance(system, HamiltonianSystem):
        E = (system.hamiltonian(q0, x["p0"]) + system.hamiltonian(q1, x["p1"])) / 2
    else:
        E = quadrature(rule, lambda q, v, *_: system.energy(q, v), q0, q1, s, ca.SX(0, 1), h) / h
    return {"midpoint_state": ca.Function("midpoint_state", [q0, q1, s, h], [q_mid, v_mid],
                                          ["q0", "q1", "s", "h"], ["q", "v"]),
            "step_energy": ca.Function("step_energy", [q0, x["p0"], q1, x["p1"], s, h], [E],
                                       ["q0", "p0", "q1", "p1", "s", "h"], ["E"])}
