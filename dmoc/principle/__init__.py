"""The principle stage: the discrete action sums (46)-(49) and the ONE step residual obtained
from them (`residual`), the forms it takes (`formulations`), the end variable a step gives
explicitly (`explicit`), the one-step-map test (`one_step`), the discrete Tulczyjew maps and
Dirac structures (34)-(42) (`tulczyjew`, `dirac`), and the Trajectory, the discrete curve
whose steps solve the residual (`trajectory`, its fields `trajectory_fields`, its file
`trajectory_file`)."""

from . import dirac, formulations
from .residual import StepResidual, action_sum, step_residual
from .trajectory import Trajectory

__all__ = ["StepResidual", "action_sum", "step_residual", "Trajectory", "dirac", "formulations"]
