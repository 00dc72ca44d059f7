"""Free goal coordinates on the group (issue 43): an entry None of ``x_goal`` leaves that
coordinate of q_N free. Checked against the same problem with the coordinate given where
the free optimum put it (the same optimum: a free entry is the best of all given ones
there), and against the problem given elsewhere (no better); bad entries refused."""

import numpy as np
import pytest

import dmoc

GOAL_R = np.array([[0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])          # a quarter turn about e3


def roll(x_goal, steps=6):
    ball = dmoc.systems.chaplygin_sphere((1.0, 1.5, 2.5), 1.3, 0.7, torques=True)
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, 3.0 / steps), steps, R_start=np.eye(3),
                                           R_goal=GOAL_R, x_start=[0.0, 0.0], x_goal=x_goal)


def test_a_free_goal_coordinate_is_where_the_optimum_puts_it():
    free = dmoc.optimize(roll([None, 0.5]))
    assert free.verdict.passed and abs(free.trajectory.x[-1, 1] - 0.5) <= 1e-10
    reached = free.trajectory.x[-1, 0]
    given = dmoc.optimize(roll([reached, 0.5]))
    assert abs(given.cost - free.cost) <= 1e-8 * free.cost
    assert np.abs(given.trajectory.u - free.trajectory.u).max() <= 1e-6
    assert dmoc.optimize(roll([reached + 0.3, 0.5])).cost > free.cost


def test_bad_goal_entries_are_refused():
    with pytest.raises(dmoc.InputError, match="`x_goal` entry 0 is NaN; only None leaves an entry free"):
        roll([np.nan, 0.5])
    with pytest.raises(dmoc.InputError, match=r"`x_goal` must have shape \(2,\)"):
        roll([None, 0.5, 1.0])
    with pytest.raises(dmoc.InputError, match="`x_goal` is required .* None entries free"):
        roll(None)
