"""The mechanics stage, first of the pipeline: a MechanicalSystem (L, the constraint
one-forms A(q) of (27), holonomic constraints g(q), a control force f) or a HamiltonianSystem,
a RigidBody on the rotation group SO(3) (`rigid_body`, its group maps `rotations`),
the checks of given data (`given`), the built-in systems with their oracles (`systems`) and
robots from their URDF files (`robots`), on a fixed, wheeled or floating base."""

from . import robots, systems
from .bodies import Body
from .rigid_body import RigidBody
from .robots import FloatingBaseRobot, RobotSystem
from .system import HamiltonianSystem, MechanicalSystem

__all__ = ["MechanicalSystem", "HamiltonianSystem", "Body", "RobotSystem", "FloatingBaseRobot", "RigidBody", "robots", "systems"]
