"""Discretization stage: quadrature rules and the discrete data L_d, omega_d (28), f_d^-/+;
for Hamiltonian systems the discrete Hamiltonians H_d+- and the discrete Legendre transform."""

from .discretization import Discretization
from .discretize import discretize
from .hamiltonian import HAMILTONIAN_RULES, HamiltonianDiscretization, HamiltonianMidpoint, HamiltonianRule, SymplecticEuler, discrete_legendre
from .rules import RULES, Lobatto3, Lobatto4, Midpoint, QuadratureRule, Trapezoid

__all__ = ["Discretization", "discretize", "QuadratureRule", "Midpoint", "Trapezoid", "Lobatto3",
           "Lobatto4", "RULES", "HamiltonianDiscretization", "HamiltonianRule", "SymplecticEuler",
           "HamiltonianMidpoint", "HAMILTONIAN_RULES", "discrete_legendre"]
