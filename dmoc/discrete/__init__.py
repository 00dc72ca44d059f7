"""Discretization stage: quadrature rules and the discrete data L_d, omega_d (28), f_d^-/+."""

from .discretization import Discretization, discretize
from .rules import RULES, Lobatto3, Lobatto4, Midpoint, QuadratureRule, Trapezoid

__all__ = ["Discretization", "discretize", "QuadratureRule", "Midpoint", "Trapezoid", "Lobatto3",
           "Lobatto4", "RULES"]
