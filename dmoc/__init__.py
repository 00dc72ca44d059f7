"""dmoc: discrete Dirac mechanics for simulation and optimal control of constrained systems."""

from .discrete import Discretization, Midpoint, Trapezoid, discretize
from .errors import DmocError, SolverError
from .principle import StepResidual, action_sum, step_residual
from .simulate import SimulationResult, simulate
from .system import MechanicalSystem
from .trajectory import Trajectory
from . import systems  # noqa: E402  (after MechanicalSystem, which it uses)

__all__ = [
    "MechanicalSystem",
    "Discretization",
    "discretize",
    "Midpoint",
    "Trapezoid",
    "StepResidual",
    "action_sum",
    "step_residual",
    "simulate",
    "SimulationResult",
    "Trajectory",
    "systems",
    "DmocError",
    "SolverError",
]
