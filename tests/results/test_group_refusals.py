"""What does not take a rigid body on SO(3) yet refuses it by name, saying what it takes
(issue 43), instead of an AttributeError from inside: the verdict's velocity bounds, the
keywords of `optimize` that the group does not take, and the diagnostics the verdict on
R^n reads."""

import numpy as np
import pytest

import dmoc
from dmoc.drivers import verdict

ON_GROUP = "a GroupOptimalControlProblem, on SO(3), has no velocity bounds"


@pytest.fixture(scope="module")
def slew():
    disc = dmoc.discretize(dmoc.systems.spacecraft((2.0, 2.0, 2.0)), 0.2)
    goal = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    problem = dmoc.GroupOptimalControlProblem(disc, 10, R_start=np.eye(3), R_goal=goal)
    return problem, dmoc.optimize(problem)


def test_the_velocity_bounds_name_the_problem_on_the_group(slew):
    problem, result = slew
    with pytest.raises(dmoc.InputTypeError, match="`problem` must be an OptimalControlProblem") as info:
        verdict.knot_velocity_bound_values(problem, result.trajectory)
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


def test_a_guess_and_jit_name_their_argument(slew):
    problem, result = slew
    with pytest.raises(dmoc.InputError, match="takes only options, throw, check, estimate, "
                                              "accuracy, max_steps; got guess, jit"):
        dmoc.optimize(problem, guess=result, jit=True)
