"""Example systems for the first stage of the pipeline: each constructor returns a
MechanicalSystem (L, the constraint one-forms A(q) of (27), a control force f) and comes with
the exact solution of its unforced Lagrange-d'Alembert equations (for the degenerate LC circuit
and point vortices, docs/degenerate.md) or, for the spherical pendulum with its holonomic
constraint, its conserved quantities (docs/holonomic.md), an oracle for measuring the
order, constraint error and energy error of the discrete principles (46)/(47). The car and
the differential drive, in SI units, have no closed form: the tests integrate their
Lagrange-d'Alembert equations with DOP853. The rigid bodies (the free rigid body, the heavy
top, a spacecraft) are `RigidBody` values on SO(3), the Chaplygin sphere one on SO(3) x R^2
with its rolling constraints, the quadrotor one on SO(3) x R^3 (its centre of mass) with a
thrust and body torques, checked by their conserved quantities and by DOP853 on their
reduced equations.
"""

from .car_model import car
from .differential_drive_model import differential_drive
from .knife_edge_model import knife_edge, knife_edge_solution
from .lc_circuit_model import lc_circuit, lc_circuit_solution
from .point_vortices_model import point_vortices, point_vortices_solution
from .rigid_body_models import (chaplygin_sphere, free_rigid_body, heavy_top, quadrotor,
                                spacecraft)
from .rolling_disk_model import rolling_disk, rolling_disk_solution
from .spherical_pendulum_model import spherical_pendulum

__all__ = ["car", "chaplygin_sphere", "differential_drive", "free_rigid_body", "heavy_top", "knife_edge",
           "knife_edge_solution", "lc_circuit", "lc_circuit_solution", "point_vortices",
           "point_vortices_solution", "quadrotor", "rolling_disk", "rolling_disk_solution",
           "spacecraft", "spherical_pendulum"]
