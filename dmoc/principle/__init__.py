"""The principle stage: the discrete action sums (46)-(49) and the ONE step residual obtained
from them (`residual`), the forms it takes (`formulations`), the end variable a step gives
explicitly (`explicit`), the one-step-map test (`one_step`), the discrete Tulczyjew maps and
Dirac structures (34)-(42) (`tulczyjew`, `dirac`, the annihilator `annihilator`), and the Trajectory, the discrete curve
whose steps solve the residual (`trajectory`, its fields `trajectory_fields`, its file
`trajectory_file`); on the rotation group, the step residual of a rigid body
(`group_residual`), its discrete curve (`rotation_trajectory`) and its left-trivialized
discrete Dirac structure (`group_dirac`)."""

from . import dirac, formulations
from .group_residual import GroupStepResidual, group_step_residual
from .residual import StepResidual, action_sum, step_residual
from .rotation_trajectory import RotationTrajectory
from .trajectory import Trajectory

__all__ = ["StepResidual", "action_sum", "step_residual", "Trajectory", "GroupStepResidual",
           "group_step_residual", "RotationTrajectory", "dirac", "formulations"]
