"""Discretization stage: quadrature rules and the discrete data L_d, omega_d (28), f_d^-/+;
for Hamiltonian systems the discrete Hamiltonians H_d+- and the discrete Legendre transform;
the discretization of a rigid body on SO(3) (`group_discretization`);
both rule families implement one interface, `Rule`; the order a rule keeps on a degenerate
Lagrangian (`degenerate`); `discretize` (module `construction`) builds the one a system takes."""

from .discretization import Discretization
from .group_discretization import GroupDiscretization
from .construction import discretize
from .hamiltonian import (HAMILTONIAN_RULES, HamiltonianDiscretization, HamiltonianMidpoint, HamiltonianRule,
                          SymplecticEuler)
from .legendre_transform import LegendreRule, discrete_legendre
from .quadrature_rules import RULES, Lobatto3, Lobatto4, Midpoint, QuadratureRule, Trapezoid
from .rules import Rule

__all__ = ["Discretization", "GroupDiscretization", "discretize", "Rule", "QuadratureRule", "Midpoint", "Trapezoid", "Lobatto3",
           "Lobatto4", "RULES", "HamiltonianDiscretization", "HamiltonianRule", "SymplecticEuler",
           "HamiltonianMidpoint", "LegendreRule", "HAMILTONIAN_RULES", "discrete_legendre"]
