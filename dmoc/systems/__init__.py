"""Example systems for the first stage of the pipeline: each constructor returns a
MechanicalSystem (L, the constraint one-forms A(q) of (27), a control force f) and comes with
the exact solution of its unforced Lagrange-d'Alembert equations, an oracle for measuring the
order, constraint error and energy error of the discrete principles (46)/(47).
"""

from .knife_edge import knife_edge, knife_edge_solution
from .rolling_disk import rolling_disk, rolling_disk_solution

__all__ = ["knife_edge", "knife_edge_solution", "rolling_disk", "rolling_disk_solution"]
