"""What the verdict's checks on R^n (`dmoc.drivers.verdict`) take: an OptimalControlProblem
and a Trajectory, not their forms on SO(3), which are refused by name where no check on
the group stands in (`knot_velocity_bound_values`: a GroupOptimalControlProblem has no
velocity bounds; `judge` and `knot_path_values` hand it to `dmoc.drivers.group_verdict`)."""

from .._util import checks
from ..optimal_control.statement.problem import OptimalControlProblem
from ..principle.trajectory import Trajectory

_PROBLEM = ("an OptimalControlProblem (a GroupOptimalControlProblem, on SO(3), has no velocity "
            "bounds; `judge` and `knot_path_values` take it)")
_TRAJECTORY = "a Trajectory (a RotationTrajectory goes with a GroupOptimalControlProblem)"


def check_judged(problem, traj, traj_name="traj"):
    """InputTypeError unless `problem` is an OptimalControlProblem and `traj` (the argument
    named `traj_name`) a Trajectory."""
    checks.instance("problem", problem, OptimalControlProblem, _PROBLEM)
    checks.instance(traj_name, traj, Trajectory, _TRAJECTORY)
