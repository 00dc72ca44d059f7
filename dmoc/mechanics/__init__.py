"""The mechanics stage, first of the pipeline: a MechanicalSystem (L, the constraint
one-forms A(q) of (27), holonomic constraints g(q), a control force f) or a HamiltonianSystem,
the checks of given data (`given`), the built-in systems with their oracles (`systems`) and
robots from their URDF files (`robots`)."""

from . import robots, systems
from .bodies import Body
from .robots import RobotSystem
from .system import HamiltonianSystem, MechanicalSystem

__all__ = ["MechanicalSystem", "HamiltonianSystem", "Body", "RobotSystem", "robots", "systems"]
