"""Robots from their URDF files, in the mechanics stage: `RobotSystem` (a robot on a fixed
base or on wheels as a MechanicalSystem, L = T - V summed over the links by the forward
recursion of `link_recursion` on the tree adam parses, the optional extra
``dmoc[robots]``), `FloatingBaseRobot` (a robot whose root link floats, on SO(3) x
R^(3 + n_s)), the joints' data read from the file (`urdf_file`), the wheels' rolling
rows (`wheeled_base`), the diagnosis of a failed step (`step_failure`) and the URDF files
shipped with dmoc (`example_urdf`).
"""

from .example_models import EXAMPLE_MODELS, example_urdf
from .floating_base import FloatingBaseRobot
from .robot_system import RobotSystem

__all__ = ["RobotSystem", "FloatingBaseRobot", "example_urdf", "EXAMPLE_MODELS"]
