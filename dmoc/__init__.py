"""dmoc: discrete Dirac mechanics for simulation and optimal control of constrained systems."""

import importlib

from .discrete import (Discretization, HamiltonianDiscretization, Lobatto3, Lobatto4, Midpoint,
                       Trapezoid, discrete_legendre, discretize)
from .errors import DmocError, InputError, InputTypeError, SolverError, TrajectoryFileError
from .ocp import OptimalControlProblem
from .optimize import OptimizationResult, optimize
from .principle import StepResidual, action_sum, step_residual
from .simulate import SimulationResult, simulate
from .system import HamiltonianSystem, MechanicalSystem
from .trajectory import Trajectory
from . import animation, diagnostics, dirac, formulations, plotting, problems, systems

__all__ = [
    "MechanicalSystem",
    "HamiltonianSystem",
    "Discretization",
    "discretize",
    "discrete_legendre",
    "HamiltonianDiscretization",
    "Midpoint",
    "Trapezoid",
    "Lobatto3",
    "Lobatto4",
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
    "problems",
    "formulations",
    "diagnostics",
    "dirac",
    "plotting",
    "animation",
    "DmocError",
    "InputError",
    "InputTypeError",
    "TrajectoryFileError",
    "SolverError",
]


def __getattr__(name):
    """`dmoc.batch` is imported on first use, so that ``import dmoc`` never imports dask."""
    if name == "batch":
        return importlib.import_module(".batch", __name__)
    raise AttributeError(f"module 'dmoc' has no attribute {name!r}")
