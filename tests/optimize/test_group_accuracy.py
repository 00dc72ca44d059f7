"""Error estimates and accuracy targets on SO(3) (issue 43): `dmoc.optimize(...,
estimate=True)` and `accuracy=` of a GroupOptimalControlProblem, judged by oracles written
here. The spacecraft slew with equal principal inertias I through theta about a fixed axis e
in T has J* = 12 I^2 theta^2 / T^3 (tests/optimize/test_group_slew.py), and its held
torques u_k parallel to e drive the continuous body exactly: theta'' = u_k . e / I on each
step, integrated in closed form, so the true end of the flow under the optimum's controls
is exp(theta(T) e^). The Chaplygin sphere rolled to a goal takes its truth from a solve on
a finer grid."""

import numpy as np
from scipy.spatial.transform import Rotation

import dmoc

QUIET = {"print_level": 0, "sb": "yes"}
I, THETA, T = 2.0, 1.2, 2.0
AXIS = np.array([1.0, 2.0, 2.0]) / 3
GOAL = Rotation.from_rotvec(THETA * AXIS).as_matrix()
J_STAR = 12 * I ** 2 * THETA ** 2 / T ** 3


def slew(steps):
    disc = dmoc.discretize(dmoc.systems.spacecraft((I, I, I)), T / steps)
    return dmoc.GroupOptimalControlProblem(disc, steps, R_start=np.eye(3), R_goal=GOAL)


def flown_end(traj):
    """R(T) of the continuous body driven by the optimum's held torques (all along AXIS)."""
    assert np.abs(np.cross(traj.u, AXIS)).max() <= 1e-12
    angle, rate = 0.0, 0.0
    for acceleration in traj.u @ AXIS / I:
        angle, rate = angle + rate * traj.h + acceleration * traj.h ** 2 / 2, rate + acceleration * traj.h
    return Rotation.from_rotvec(angle * AXIS).as_matrix()


def end_error(traj):
    """max_i |R_N,i - R_i(T)| over the excursion of entry i, as ErrorEstimate.final_state."""
    excursion = np.ptp(traj.R.reshape(-1, 9), axis=0)
    return np.max(np.abs(traj.R[-1] - flown_end(traj)).ravel() / excursion)


def test_the_slews_estimate_is_its_true_error():
    """N = 6 against N = 3: the estimated cost error and end error each within 10 % of the
    closed forms' (order 1 or 4 would be off by 3 or 5 times)."""
    result = dmoc.optimize(slew(6), estimate=True, options=QUIET)
    estimate = result.stats["error_estimate"]
    assert result.success and result.verdict.passed and estimate["reference_steps"] == 3
    assert estimate["order"] == 2 and not estimate["switching"] and estimate["final_time"] == 0.0
    assert 0.9 <= estimate["cost_error"] / (result.cost - J_STAR) <= 1.5
    assert 0.9 <= estimate["final_state"] / end_error(result.trajectory) <= 1.1
    assert result.verdict.discretization_error == max(estimate["cost"], estimate["final_state"])


def test_the_slew_refined_to_an_accuracy_meets_it():
    """From N = 4 to a target of 3e-3: success, and the true relative errors of the cost and
    of the end (closed forms) are below the target."""
    tol = 3e-3
    result = dmoc.optimize(slew(4), accuracy=tol, options=QUIET)
    levels = [level["steps"] for level in result.stats["levels"]]
    assert result.success and levels[:2] == [4, 8] and len(levels) >= 3, levels
    assert f"Accuracy {tol:g} reached on {levels[-1]} steps (midpoint)" in result.message
    assert abs(result.cost - J_STAR) / result.cost <= tol
    assert end_error(result.trajectory) <= tol
    assert result.stats["error_estimate"]["steps"] == levels[-1]


def test_a_target_beyond_max_steps_is_not_reached_on_the_group():
    result = dmoc.optimize(slew(4), accuracy=1e-6, max_steps=10, throw=False, options=QUIET)
    assert (result.success, result.status) == (False, "accuracy_not_reached")
    assert "raise `max_steps`." in result.message and "lobatto" not in result.message


def test_the_sphere_rolled_to_a_goal_meets_its_accuracy():
    """The Chaplygin sphere from (I, 0) to a quarter turn at (1, 0.5) in 4 s: the target
    2e-2 from N = 8 is met by the cost against a solve on 48 steps, whose own error is
    (16/48)^2 = 1/9 of the 16-step one's at order 2 (tests/optimize/test_sphere_roll.py):
    the truth J_16 - J* = (J_16 - J_48) 9/8; the estimate within a factor 1.5 of it."""
    ball = dmoc.systems.chaplygin_sphere(np.array([1.0, 1.5, 2.5]), 1.3, 0.7, torques=True)
    goal = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()

    def roll(steps):
        return dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, 4.0 / steps), steps,
                                               R_start=np.eye(3), R_goal=goal, x_start=[0.0, 0.0],
                                               x_goal=[1.0, 0.5])
    tol = 2e-2
    result = dmoc.optimize(roll(8), accuracy=tol, options=QUIET)
    fine = dmoc.optimize(roll(48), options=QUIET)
    assert result.success and result.trajectory.steps == 16
    true_error = (result.cost - fine.cost) * 9 / 8
    assert 0 < true_error / result.cost <= tol
    assert 1 / 1.5 <= result.stats["error_estimate"]["cost_error"] / true_error <= 1.5
