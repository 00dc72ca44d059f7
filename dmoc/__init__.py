"""dmoc: discrete Dirac mechanics for simulation and optimal control of constrained systems.

The package reads as its pipeline, one folder a stage: `mechanics` (the system) →
`discrete` (the discretization) → `principle` (the one step residual) → `simulate` and
`optimize` (its two consumers) → `results`; `batch` and `cli` use the public API. This
module re-exports the public names; ``dmoc.systems``, ``dmoc.problems``,
``dmoc.diagnostics``, ``dmoc.plotting``, ``dmoc.animation``, ``dmoc.dirac`` and
``dmoc.formulations`` are the stage modules of those names.
"""

import importlib
import sys

from ._util.cache import clear_caches
from .discrete import (Discretization, HamiltonianDiscretization, Lobatto3, Lobatto4, Midpoint,
                       Trapezoid, discrete_legendre, discretize)
from .errors import (CompiledCodeError, DmocError, InputError, InputTypeError, Interrupted,
                     MissingFileError, SolverError, TrajectoryFileError)
from .mechanics import Body, HamiltonianSystem, MechanicalSystem, systems
from .optimize import (MPC, OptimalControlProblem, OptimizationResult, Verdict, from_waypoints,
                       problems)
from .principle import StepResidual, Trajectory, action_sum, dirac, formulations, step_residual
from .results import animation, diagnostics, optimize, plotting
from .simulate import SimulationResult, simulate

# The public module names of the stages' modules: ``from dmoc.systems import knife_edge``
# works as ``dmoc.systems.knife_edge`` does.
for _module in (systems, problems, diagnostics, plotting, animation, dirac, formulations):
    sys.modules[f"{__name__}.{_module.__name__.rsplit('.', 1)[1]}"] = _module
del _module

__all__ = [
    "MechanicalSystem",
    "HamiltonianSystem",
    "Body",
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
    "Verdict",
    "from_waypoints",
    "MPC",
    "Trajectory",
    "systems",
    "problems",
    "formulations",
    "diagnostics",
    "dirac",
    "plotting",
    "animation",
    "clear_caches",
    "DmocError",
    "InputError",
    "InputTypeError",
    "TrajectoryFileError",
    "MissingFileError",
    "SolverError",
    "CompiledCodeError",
    "Interrupted",
]


def __getattr__(name):
    """`dmoc.batch` is imported on first use, so that ``import dmoc`` never imports dask."""
    if name == "batch":
        return importlib.import_module(".batch", __name__)
    raise AttributeError(f"module 'dmoc' has no attribute {name!r}")
