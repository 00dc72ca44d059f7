"""The mechanics stage, first of the pipeline: a MechanicalSystem (L, the constraint
one-forms A(q) of (27), holonomic constraints g(q), a control force f) or a HamiltonianSystem,
the checks of given data (`given`), and the built-in systems with their oracles (`systems`)."""

from . import systems
from .bodies import Body
from .system import HamiltonianSystem, MechanicalSystem

__all__ = ["MechanicalSystem", "HamiltonianSystem", "Body", "systems"]
