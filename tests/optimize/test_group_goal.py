"""Free goal coordinates on the group (issue 43): an entry None of ``x_goal`` leaves that
coordinate of q_N free, ``R_goal`` None the rotation at the goal as a whole. Checked against the same problem with the coordinate given where
the free optimum put it (the same optimum: a free entry is the best of all given ones
there), and against the problem given elsewhere (no better); bad entries refused."""

import numpy as np
import pytest

import dmoc

GOAL_R = np.array([[0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])          # a quarter turn about e3


def roll(x_goal, steps=6, R_goal=GOAL_R, **ends):
    ball = dmoc.systems.chaplygin_sphere((1.0, 1.5, 2.5), 1.3, 0.7, torques=True)
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, 3.0 / steps), steps, R_start=np.eye(3),
                                           R_goal=R_goal, x_start=[0.0, 0.0], x_goal=x_goal, **ends)


def test_a_free_goal_coordinate_is_where_the_optimum_puts_it():
    free = dmoc.optimize(roll([None, 0.5]))
    assert free.verdict.passed and abs(free.trajectory.x[-1, 1] - 0.5) <= 1e-10
    reached = free.trajectory.x[-1, 0]
    given = dmoc.optimize(roll([reached, 0.5]))
    assert abs(given.cost - free.cost) <= 1e-8 * free.cost
    assert np.abs(given.trajectory.u - free.trajectory.u).max() <= 1e-6
    assert dmoc.optimize(roll([reached + 0.3, 0.5])).cost > free.cost


def test_a_free_goal_rotation_is_where_the_optimum_turns_the_ball():
    """Rolled to (1, 0.5) in any orientation: R_N a rotation the NLP did not aim at, the
    problem given it there has the same optimum, and the quarter turn costs more."""
    free = dmoc.optimize(roll([1.0, 0.5], R_goal=None))
    R_N = free.trajectory.R[-1]
    assert free.verdict.passed and np.abs(free.trajectory.x[-1] - [1.0, 0.5]).max() <= 1e-10
    assert np.abs(R_N.T @ R_N - np.eye(3)).max() <= 1e-13 and np.abs(R_N - GOAL_R).max() > 0.1
    given = dmoc.optimize(roll([1.0, 0.5], R_goal=R_N))
    assert abs(given.cost - free.cost) <= 1e-8 * free.cost
    assert np.abs(given.trajectory.u - free.trajectory.u).max() <= 1e-6
    assert dmoc.optimize(roll([1.0, 0.5])).cost > free.cost


def test_bad_goal_entries_are_refused():
    with pytest.raises(dmoc.InputError, match="`x_goal` entry 0 is NaN; only None leaves an entry free"):
        roll([np.nan, 0.5])
    with pytest.raises(dmoc.InputError, match=r"`x_goal` must have shape \(2,\)"):
        roll([None, 0.5, 1.0])
    with pytest.raises(dmoc.InputError, match="`x_goal` is required .* None entries free"):
        roll(None)
    with pytest.raises(dmoc.InputError, match="`R_goal` is free .* goal's velocity is not zero"):
        roll([1.0, 0.5], R_goal=None, omega_goal=[1.0, 0.0, 0.0],
             x_velocity_goal=[0.0, -0.7])          # rolling at R = I: x' = r (omega x e3)
