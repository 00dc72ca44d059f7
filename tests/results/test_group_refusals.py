"""What does not take a rigid body on SO(3) yet refuses it by name, saying what it takes
(issue 43), instead of an AttributeError from inside: the verdict's public checks, the
accuracy target, the error estimate and the diagnostics the verdict reads."""

import numpy as np
import pytest

import dmoc
from dmoc.drivers import verdict
from dmoc.drivers.error_estimate import estimate_error

ON_GROUP = "a GroupOptimalControlProblem, on SO(3), is judged by `dmoc.optimize` itself"


@pytest.fixture(scope="module")
def slew():
    disc = dmoc.discretize(dmoc.systems.spacecraft((2.0, 2.0, 2.0)), 0.2)
    goal = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    problem = dmoc.GroupOptimalControlProblem(disc, 10, R_start=np.eye(3), R_goal=goal)
    return problem, dmoc.optimize(problem)


@pytest.mark.parametrize("call", [
    lambda problem, result: verdict.judge(problem, result),
    lambda problem, result: verdict.knot_path_values(problem, result.trajectory),
    lambda problem, result: verdict.knot_velocity_bound_values(problem, result.trajectory),
])
def test_the_verdicts_checks_name_the_problem_on_the_group(slew, call):
    with pytest.raises(dmoc.InputTypeError, match="`problem` must be an OptimalControlProblem") as info:
        call(*slew)
    assert ON_GROUP in str(info.value) and "got GroupOptimalControlProblem" in str(info.value)


def test_a_rotation_trajectory_is_named_with_a_vector_problem(slew):
    problem = dmoc.problems.rolling_disk_steering(4)
    with pytest.raises(dmoc.InputTypeError, match="`traj` must be a Trajectory .*got RotationTrajectory"):
        verdict.knot_path_values(problem, slew[1].trajectory)
    with pytest.raises(dmoc.InputTypeError, match="`traj` must be a Trajectory; got RotationTrajectory"):
        dmoc.diagnostics.compared_momenta(problem, slew[1].trajectory)


def test_the_diagnostics_the_verdict_reads_name_the_discretization(slew):
    problem, result = slew
    with pytest.raises(dmoc.InputTypeError, match="`disc` must be a Discretization; got GroupDiscretization"):
        dmoc.diagnostics.end_velocities(problem.disc, result.trajectory)
    with pytest.raises(dmoc.InputTypeError, match="`problem` must be an OptimalControlProblem; "
                                                  "got GroupOptimalControlProblem"):
        dmoc.diagnostics.compared_momenta(problem, result.trajectory)


def test_accuracy_and_the_error_estimate_name_their_argument(slew):
    problem, result = slew
    with pytest.raises(dmoc.InputError, match="takes only options, throw, check; got accuracy"):
        dmoc.optimize(problem, accuracy=1e-3)
    with pytest.raises(dmoc.InputTypeError, match="`problem` must be an OptimalControlProblem"):
        estimate_error(problem, result)
