"""What the verdict's public checks (`dmoc.drivers.verdict`) take: an OptimalControlProblem
and a Trajectory, not their forms on SO(3), which are refused by name (a
GroupOptimalControlProblem is judged by `dmoc.optimize` itself, by its replay:
`dmoc.drivers.group_optimum`)."""

from .._util import checks
from ..optimal_control.statement.problem import OptimalControlProblem
from ..principle.trajectory import Trajectory

_PROBLEM = ("an OptimalControlProblem (a GroupOptimalControlProblem, on SO(3), is judged by "
            "`dmoc.optimize` itself: its replay, stats['replay_deviation'])")
_TRAJECTORY = "a Trajectory (a RotationTrajectory, on SO(3), has no verdict's checks)"


def check_judged(problem, traj, traj_name="traj"):
    """InputTypeError unless `problem` is an OptimalControlProblem and `traj` (the argument
    named `traj_name`) a Trajectory."""
    checks.instance("problem", problem, OptimalControlProblem, _PROBLEM)
    checks.instance(traj_name, traj, Trajectory, _TRAJECTORY)
