"""Discretization stage: quadrature rules and the discrete data L_d, omega_d (28), f_d^-/+."""

from .discretization import Discretization, discretize
from .rules import RULES, Midpoint, QuadratureRule, Trapezoid

__all__ = ["Discretization", "discretize", "QuadratureRule", "Midpoint", "Trapezoid", "RULES"]
