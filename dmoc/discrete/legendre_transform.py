"""Discretization stage, the discrete Legendre transform (Lall & West): from a Lagrangian
discretization the Hamiltonian one whose discrete Hamiltonians are
H_d+(q_k, p_{k+1}) = ext_Q p_{k+1} . Q - L_d(q_k, Q) and H_d-(p_k, q_{k+1}) =
ext_Q -p_k . Q - L_d(Q, q_{k+1}), the extremizing configuration Q a stage unknown of the
residual (`LegendreRule`, `discrete_legendre`). Simulated from the same data it reproduces
the Lagrangian trajectory: the step equations (37)/(41) written as (39)/(43)
(docs/hamiltonian.md; docs/theory.md, "Hamiltonian side").
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .._util.layout import step_symbols
from ..errors import InputError, InputTypeError
from ..mechanics.system import MechanicalSystem
from .discretization import Discretization, constraint_function
from .hamiltonian import HamiltonianDiscretization, end_functions
from .quadrature_rules import QuadratureRule
from .rules import Rule


@dataclass(frozen=True)
class LegendreRule(Rule):
    """The discrete Legendre transform of a Lagrangian rule (Lall & West):
    H_d+(q0, p1) = ext_Q p1 . Q - L_d(q0, Q, sigma) and
    H_d-(p0, q1) = ext_Q -p0 . Q - L_d(Q, q1, sigma), stages s = (Q, sigma), sigma the
    Lagrangian rule's own stages; the forces are the Lagrangian rule's f_d^-+. Its order,
    control nodes and interpolant are the Lagrangian rule's; its one multiplier sits at the
    end node, as in (38)/(42).

    >>> from dmoc.discrete import Lobatto3
    >>> rule = LegendreRule(Lobatto3())
    >>> rule.order, rule.n_stage_blocks, rule.stage_nodes, rule.has_interior_multipliers
    (4, 2, (0.5,), False)
    """

    lagrangian_rule: QuadratureRule

    has_interior_multipliers = False

    @property
    def name(self):
        return f"legendre-{self.lagrangian_rule.name}"

    @property
    def order(self):
        return self.lagrangian_rule.order

    @property
    def n_stage_blocks(self):
        return 1 + self.lagrangian_rule.n_stage_blocks

    @property
    def control_nodes(self):
        return self.lagrangian_rule.control_nodes

    @property
    def interpolant(self):
        return self.lagrangian_rule

    def stage_guess(self, q, p):
        """Q = q_{k+1}, the Lagrangian rule's stages on the chords."""
        return np.hstack([q[1:], self.lagrangian_rule.stage_guess(q, p)])

    def __repr__(self):
        return f"LegendreRule({self.lagrangian_rule!r})"


def discrete_legendre(disc):
    """The Hamiltonian discretization whose H_d+ (and H_d-) is the discrete Legendre
    transform of the Lagrangian discretization `disc` (Lall & West), implicit: the
    extremizing configuration is a stage unknown of the residual.

    Simulated from the same (q_0, p_0), it reproduces the Lagrangian trajectory (the step
    equations are (37)/(41) written as (39)/(43)).

    Parameters
    ----------
    disc : Discretization
        A Lagrangian discretization; with constraints, a rule without interior multipliers
        (``rule.has_interior_multipliers`` False: those of a Lagrangian stage rule sit at
        its interior nodes, which (38)/(42) do not have).

    Returns
    -------
    HamiltonianDiscretization
    """
    if not isinstance(disc, Discretization) or isinstance(disc, HamiltonianDiscretization):
        raise InputTypeError(f"`disc` must be a Lagrangian Discretization; got {type(disc).__name__}.")
    if disc.system.m and disc.rule.has_interior_multipliers:
        raise InputError(f"`disc` must have a stage-free rule when it has constraints: rule "
                         f"{disc.rule.name!r} puts multipliers at its interior nodes.")
    return LegendreDiscretization(disc)


class LegendreDiscretization(HamiltonianDiscretization):
    """The HamiltonianDiscretization of `discrete_legendre`: stages (Q, sigma), the running
    cost integrated by the Lagrangian rule on (q0, q1, sigma) (its interpolant)."""

    system_type = MechanicalSystem
    system_described = "a MechanicalSystem"

    def __init__(self, lagrangian):
        self.lagrangian = lagrangian
        super().__init__(lagrangian.system, lagrangian.h, LegendreRule(lagrangian.rule))

    def _as_rule(self, rule):
        return rule

    def _declared_order(self):
        return self.lagrangian.order

    def _functions(self):
        """H_d+- from the Lagrangian discretization's L_d and f_d, h an input."""
        disc, n = self.lagrangian, self.system.n
        x = step_symbols(n, self.n_stages, self.n_controls)
        Q, sigma = x["s"][:n], x["s"][n:]
        L_d = disc.discrete_lagrangian
        Hp = ca.dot(x["p1"], Q) - L_d(x["q0"], Q, sigma, x["h"])
        Hm = -ca.dot(x["p0"], Q) - L_d(Q, x["q1"], sigma, x["h"])
        f_minus, f_plus, f_sigma = disc.discrete_force(x["q0"], Q, sigma, x["u"], x["h"])
        g_minus, g_plus, g_sigma = disc.discrete_force(Q, x["q1"], sigma, x["u"], x["h"])
        fp = (f_minus, ca.vertcat(f_plus, f_sigma))
        fm = (g_plus, ca.vertcat(g_minus, g_sigma))
        return {**end_functions(x, Hp, Hm, fp, fm),
                "discrete_constraint": constraint_function(self.system, self.rule, x)}


__all__ = ["LegendreRule", "LegendreDiscretization", "discrete_legendre"]
