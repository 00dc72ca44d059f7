"""Discretization of a Hamiltonian system: right and left discrete Hamiltonians H_d+(q_k,
p_{k+1}) and H_d-(p_k, q_{k+1}) (type-2 and type-3 generating functions, Lall & West), by
named rules or supplied by the user (the discrete Legendre transform of a Lagrangian
discretization is `dmoc.discrete.legendre_transform`); both rule kinds implement
`dmoc.discrete.rules.Rule`. The discrete constraints are those of (28) on the rule's
interpolant (the midpoint retraction of the chord, and g(q_{k+1}) = 0 for holonomic
constraints), the discrete forces the virtual work of f(q, p, u) at the rule's samples. The
residual rows come from the sums (48)/(49) (`dmoc.formulations.hamiltonian`).
"""

from abc import abstractmethod
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .._util import checks
from .._util.layout import step_symbols
from ..mechanics.system import HamiltonianSystem
from .discretization import Discretization, constraint_function
from .quadrature_rules import Midpoint
from .rules import Rule, virtual_work


@dataclass(frozen=True)
class HamiltonianRule(Rule):
    """A pair of discrete Hamiltonians with their stage unknowns: the Hamiltonian family of
    `Rule`.

    Subclasses define `right` and `left`: ``right(H, q0, p1, s, h) -> (H_d+, samples)``
    and ``left(H, p0, q1, s, h) -> (H_d-, samples)``, H the Function H(q, p), s the stage
    unknowns (``n_stage_blocks * n`` rows; H_d is extremal in them), samples a list of
    (weight, q, p, c) at which the force f(q, p, u(c)) does virtual work weight f . delta q
    (`dmoc.discrete.rules.virtual_work`), c the step time of the sample.

    Attributes
    ----------
    name : str
    order : int
    n_stage_blocks : int
        Stage unknowns per step, in units of n.
    control_nodes : tuple of float
        ``(0.5,)``: one control held over each step.
    interpolant : QuadratureRule
        `Midpoint`: omega_d (28) with the midpoint retraction (and g(q_{k+1})), the midpoint
        state and the running cost are taken on the chord.
    has_interior_multipliers : bool
        False: the one multiplier of (38)/(42) sits at the formulation's end node.
    """

    name: str
    order: int
    n_stage_blocks: int = 0
    control_nodes: tuple = (0.5,)

    interpolant = Midpoint()
    has_interior_multipliers = False

    @abstractmethod
    def right(self, H, q0, p1, s, h):
        """(H_d+(q0, p1), samples)."""

    @abstractmethod
    def left(self, H, p0, q1, s, h):
        """(H_d-(p0, q1), samples)."""

    def stage_guess(self, q, p):
        """Stage values for an initial guess from knot values q, p (N+1, n): (N, n_stages).
        Rules with stages override it."""
        return np.zeros((q.shape[0] - 1, 0))


class SymplecticEuler(HamiltonianRule):
    """H_d+ = p1 . q0 + h H(q0, p1), H_d- = -p0 . q1 + h H(q1, p0): the two symplectic
    Euler methods (order 1), no stages; the force acts at the same sample.

    >>> SymplecticEuler().order
    1
    """

    def __init__(self):
        super().__init__("symplectic-euler", 1)

    def right(self, H, q0, p1, s, h):
        return ca.dot(p1, q0) + h * H(q0, p1), [(h, q0, p1, 0.0)]

    def left(self, H, p0, q1, s, h):
        return -ca.dot(p0, q1) + h * H(q1, p0), [(h, q1, p0, 1.0)]

    def __repr__(self):
        return "SymplecticEuler()"


class HamiltonianMidpoint(HamiltonianRule):
    """The Galerkin discrete Hamiltonians on a linear q and a constant P with the midpoint
    quadrature (after Leok & Zhang), order 2; stages s = (Q, P):

    H_d+(q0, p1) = ext_{Q, P} p1 . Q - P . (Q - q0) + h H((q0 + Q)/2, P)  (Q = q_{k+1}),
    H_d-(p0, q1) = ext_{Q, P} -p0 . Q - P . (q1 - Q) + h H((Q + q1)/2, P)  (Q = q_k).

    Both give the implicit midpoint rule; the force acts at the midpoint.

    >>> HamiltonianMidpoint().n_stage_blocks
    2
    """

    def __init__(self):
        super().__init__("midpoint", 2, 2)

    def stage_guess(self, q, p):
        """Q = q_{k+1} (+; q_k for -, both near), P = (p_k + p_{k+1})/2."""
        return np.hstack([q[1:], (p[:-1] + p[1:]) / 2])

    def right(self, H, q0, p1, s, h):
        n = q0.numel()
        Q, P = s[:n], s[n:]
        mid = (q0 + Q) / 2
        return ca.dot(p1, Q) - ca.dot(P, Q - q0) + h * H(mid, P), [(h, mid, P, 0.5)]

    def left(self, H, p0, q1, s, h):
        n = q1.numel()
        Q, P = s[:n], s[n:]
        mid = (Q + q1) / 2
        return -ca.dot(p0, Q) - ca.dot(P, q1 - Q) + h * H(mid, P), [(h, mid, P, 0.5)]

    def __repr__(self):
        return "HamiltonianMidpoint()"


HAMILTONIAN_RULES = {rule().name: rule for rule in (SymplecticEuler, HamiltonianMidpoint)}


class HamiltonianDiscretization(Discretization):
    """Discrete data of a HamiltonianSystem (or of a Lagrangian discretization's Legendre
    transform) on a grid of step `h`; build it with `dmoc.discretize` or
    `dmoc.discrete_legendre`.

    Attributes
    ----------
    system, h, rule, key, n_stages, n_multipliers, n_controls
        As for `Discretization` (derived from the rule there); `rule` is a
        HamiltonianRule (a LegendreRule for `discrete_legendre`).
    right_hamiltonian, left_hamiltonian : casadi.Function
        ``H_d+(q0, p1, s, h)`` and ``H_d-(p0, q1, s, h)``, scalars, stage-extended.
    right_force, left_force : casadi.Function
        ``(q0, p1, s, u, h) -> (f_q0, f_stage)`` and ``(p0, q1, s, u, h) -> (f_q1,
        f_stage)``: the discrete virtual work of f on delta q_k (resp. delta q_{k+1}) and on
        the stages, for the (+) and (-) forms.
    discrete_constraint, midpoint_state, step_energy
        As for `Discretization`, on the rule's interpolant (the chord for a HamiltonianRule);
        the energy of a step is (H(q0, p0) + H(q1, p1))/2 for a HamiltonianSystem.
    """

    family = "hamiltonian"
    system_type = HamiltonianSystem
    system_described = "a HamiltonianSystem"
    function_names = ("right_hamiltonian", "left_hamiltonian", "right_force", "left_force",
                      "discrete_constraint")

    def _as_rule(self, rule):
        return as_hamiltonian_rule(rule)

    def _declared_order(self):
        return self.rule.order

    def _functions(self):
        """The Functions of a HamiltonianRule's discretization, h an input."""
        system, rule = self.system, self.rule
        x = step_symbols(system.n, self.n_stages, self.n_controls)
        Hp, right_samples = rule.right(system.hamiltonian, x["q0"], x["p1"], x["s"], x["h"])
        Hm, left_samples = rule.left(system.hamiltonian, x["p0"], x["q1"], x["s"], x["h"])
        fp = virtual_work(rule, system.force, right_samples, x["u"], (x["q0"], x["s"]))
        fm = virtual_work(rule, system.force, left_samples, x["u"], (x["q1"], x["s"]))
        return {**end_functions(x, Hp, Hm, fp, fm),
                "discrete_constraint": constraint_function(system, rule, x)}

    def __repr__(self):
        return f"HamiltonianDiscretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


def as_hamiltonian_rule(rule):
    """A HamiltonianRule from an instance or one of the names in HAMILTONIAN_RULES."""
    if isinstance(rule, HamiltonianRule):
        return rule
    return HAMILTONIAN_RULES[checks.choice("rule", rule, tuple(HAMILTONIAN_RULES))]()


def end_functions(x, Hp, Hm, fp, fm):
    """H_d+, H_d-, and their discrete forces as named Functions of the step symbols `x`."""
    def function(name, inputs, outputs, output_names):
        inputs = inputs.split(",")
        return ca.Function(name, [x[a] for a in inputs], outputs, inputs, output_names)
    return {"right_hamiltonian": function("H_d_plus", "q0,p1,s,h", [Hp], ["H_d"]),
            "left_hamiltonian": function("H_d_minus", "p0,q1,s,h", [Hm], ["H_d"]),
            "right_force": function("f_d_plus", "q0,p1,s,u,h", list(fp), ["f_q0", "f_stage"]),
            "left_force": function("f_d_minus", "p0,q1,s,u,h", list(fm), ["f_q1", "f_stage"])}


__all__ = ["HamiltonianRule", "SymplecticEuler", "HamiltonianMidpoint", "HAMILTONIAN_RULES",
           "HamiltonianDiscretization"]
