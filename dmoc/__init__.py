"""dmoc: discrete Dirac mechanics for simulation and optimal control of constrained systems."""

from .discrete import Discretization, Midpoint, Trapezoid, discretize
from .errors import DmocError, SolverError
from .ocp import OptimalControlProblem
from .optimize import OptimizationResult, optimize
from .principle import StepResidual, action_sum, step_residual
from .simulate import SimulationResult, simulate
from .system import MechanicalSystem
from .trajectory import Trajectory
from . import animation, diagnostics, dirac, plotting, systems

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
    "OptimalControlProblem",
    "optimize",
    "OptimizationResult",
    "Trajectory",
    "systems",
    "diagnostics",
    "dirac",
    "plotting",
    "animation",
    "DmocError",
    "SolverError",
]
