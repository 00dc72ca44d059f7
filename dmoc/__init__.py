"""dmoc: discrete Dirac mechanics for simulation and optimal control of constrained systems.

The package reads as its pipeline, one folder a stage: `mechanics` (the system) →
`discrete` (the discretization) → `principle` (the one step residual) → `simulation` and
`optimal_control` (its two consumers) → `results` (diagnostics, plots) → `drivers` (the
judged `optimize`, its accuracy, the MPC); `batch` and `cli` use the public API. This module
re-exports the public names; ``dmoc.systems``, ``dmoc.problems``, ``dmoc.diagnostics``,
``dmoc.plotting``, ``dmoc.animation``, ``dmoc.dirac`` and ``dmoc.formulations`` are the
stage modules of those names; ``dmoc.batch`` is imported on first use.
"""

from ._util.cache import clear_caches
from .discrete import (Discretization, GroupDiscretization, HamiltonianDiscretization, Lobatto3, Lobatto4, Midpoint,
                       Trapezoid, discrete_legendre, discretize)
from .errors import (CompiledCodeError, DmocError, InputError, InputTypeError, Interrupted,
                     MissingFileError, SolverError, Status, TrajectoryFileError)
from .mechanics import Body, FloatingBaseRobot, HamiltonianSystem, MechanicalSystem, RigidBody, RobotSystem, systems
from .optimal_control import (GroupOptimalControlProblem, OptimalControlProblem, OptimizationResult, Verdict,
                              from_waypoints)
from .optimal_control.statement import examples as problems
from .principle import (GroupStepResidual, RotationTrajectory, StepResidual, Trajectory, action_sum,
                        dirac, formulations, group_step_residual, step_residual)
from .results import animation, diagnostics, plotting
from .simulation import SimulationResult, simulate
from .drivers.flow_linearization import flow_jacobians
from .drivers.mpc import MPC
from .drivers.riccati import FeedbackGains, tvlqr
from .drivers.parametric_sensitivity import Sensitivities, sensitivities
from .drivers.optimum import optimize
from ._util.public_modules import publish

publish(__name__, {"systems": systems, "problems": problems, "diagnostics": diagnostics,
                   "plotting": plotting, "animation": animation, "dirac": dirac,
                   "formulations": formulations})
del publish

__all__ = [
    "MechanicalSystem",
    "HamiltonianSystem",
    "RobotSystem",
    "FloatingBaseRobot",
    "RigidBody",
    "Body",
    "Discretization",
    "discretize",
    "discrete_legendre",
    "HamiltonianDiscretization",
    "GroupDiscretization",
    "Midpoint",
    "Trapezoid",
    "Lobatto3",
    "Lobatto4",
    "StepResidual",
    "action_sum",
    "step_residual",
    "GroupStepResidual",
    "group_step_residual",
    "simulate",
    "SimulationResult",
    "OptimalControlProblem",
    "GroupOptimalControlProblem",
    "optimize",
    "OptimizationResult",
    "Verdict",
    "from_waypoints",
    "MPC",
    "flow_jacobians",
    "tvlqr",
    "sensitivities",
    "Sensitivities",
    "FeedbackGains",
    "Trajectory",
    "RotationTrajectory",
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
    "Status",
]


def __getattr__(name):
    """`dmoc.batch` is imported on first use, so that ``import dmoc`` never imports dask."""
    if name == "batch":
        import dmoc.batch
        return dmoc.batch
    raise AttributeError(f"module 'dmoc' has no attribute {name!r}")
