"""dmoc.from_waypoints: a guess through the user's waypoints on a problem's grid.

Oracles written here: waypoints on a line and on a parabola in time (the curve, its
velocity and the momenta p = M q' in closed form, M = diag(m, m, J) of the knife edge,
which the piecewise cubic reproduces exactly); the optimum from the default guess (the
same problem must reach the same cost from the waypoint guess); a free final time's
range T_min/N ... T_max/N for the guess's step.
"""

import numpy as np
import pytest

import dmoc
from dmoc import from_waypoints

MASS, INERTIA = 2.0, 0.5
M = np.array([MASS, MASS, INERTIA])
A, B, C = np.array([0.1, -0.2, 0.3]), np.array([0.5, 0.25, -0.4]), np.array([0.3, -0.6, 0.2])


def disc(rule="midpoint", h=0.1):
    return dmoc.discretize(dmoc.systems.knife_edge(mass=MASS, inertia=INERTIA), h, rule)


@pytest.mark.parametrize("rule", ["midpoint", "lobatto3", "lobatto4"])
def test_waypoints_on_a_parabola_give_the_parabola(rule):
    """q(t) = A + B t + C t^2 through 4 unevenly timed waypoints: the guess's dense q, v
    and its knot momenta are those of the parabola."""
    times = np.array([0.0, 0.3, 1.1, 2.0])
    guess = from_waypoints(disc(rule), A + np.outer(times, B) + np.outer(times ** 2, C), times,
                           steps=20)
    t = np.linspace(0, 2.0, 57)
    np.testing.assert_allclose(guess.q, A + np.outer(guess.t, B) + np.outer(guess.t ** 2, C),
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(guess.p, M * (B + 2 * np.outer(guess.t, C)), rtol=0, atol=1e-13)
    if rule != "midpoint":       # the rule's interpolant of degree >= 2 holds the parabola
        dense = guess.sample(t)
        np.testing.assert_allclose(dense.q, A + np.outer(t, B) + np.outer(t ** 2, C), rtol=0, atol=1e-14)
        np.testing.assert_allclose(dense.v, B + 2 * np.outer(t, C), rtol=0, atol=1e-12)
    assert guess.s.shape == (20, 3 * len(guess.stage_nodes)) and not guess.u.any()


def test_two_waypoints_give_the_line_and_its_momentum():
    guess = from_waypoints(disc(), [A, A + 2 * B], steps=20)
    np.testing.assert_allclose(guess.q, A + np.outer(guess.t, B), rtol=0, atol=1e-14)
    np.testing.assert_allclose(guess.p, np.tile(M * B, (21, 1)), rtol=0, atol=1e-14)


def test_a_problem_gives_the_grid_and_the_end_velocities():
    v_start = np.array([0.3, 0.0, 0.2])
    problem = dmoc.OptimalControlProblem(disc(), 20, q_start=[0, 0, 0], q_goal=[0, 1, 0], v_start=v_start)
    waypoints = [[0, 0, 0], [0.3, 0.5, 0.6], [0, 1, 0]]
    guess = from_waypoints(problem, waypoints)
    np.testing.assert_array_equal(guess.q[[0, 10, 20]], waypoints)
    np.testing.assert_allclose(guess.p[0], M * v_start, rtol=0, atol=1e-15)     # given slope
    np.testing.assert_allclose(guess.p[-1], 0, rtol=0, atol=1e-15)              # at rest
    assert guess.variant == "+" and from_waypoints(
        dmoc.problems.knife_edge_parking(10, variant="-"), waypoints).variant == "-"


def test_the_waypoint_guess_reaches_the_optimum_of_the_default_guess():
    problem = dmoc.problems.knife_edge_parking(30, rule="lobatto3")
    reference = dmoc.optimize(problem)
    result = dmoc.optimize(problem, guess=from_waypoints(
        problem, [[0, 0, 0], [0.2, 0.3, 0.8], [0.2, 0.7, 0.8], [0, 1, 0]]))
    assert result.success
    np.testing.assert_allclose(result.cost, reference.cost, rtol=1e-8)
    np.testing.assert_allclose(result.trajectory.q, reference.trajectory.q, rtol=0, atol=1e-6)


def test_bad_waypoints_are_refused():
    with pytest.raises(dmoc.InputError, match=r"`q` must have shape \(K, 3\) with K >= 2"):
        from_waypoints(disc(), [[0, 0, 0]], steps=10)
    with pytest.raises(dmoc.InputError, match=r"`times` must increase from 0 to the horizon N h = 1.0"):
        from_waypoints(disc(), [[0, 0, 0], [1, 1, 1]], [0.0, 0.9], steps=10)
    with pytest.raises(dmoc.InputError, match="`steps` is required with a Discretization"):
        from_waypoints(disc(), [[0, 0, 0], [1, 1, 1]])
    with pytest.raises(dmoc.InputTypeError, match="`target` must be an OptimalControlProblem or a "
                                                  "Discretization"):
        from_waypoints("problem", [[0, 0, 0], [1, 1, 1]])


def test_a_free_final_time_gives_a_grid_within_its_range():
    """disc.h = 0.1 over 10 steps is 1 s, outside the free final time's [2, 3] s: the
    guess's grid is 10 steps of T_min/N = 0.2 (the nearest step in range), the line from
    A to A + 2 B in 2 s with the momenta M B."""
    problem = dmoc.OptimalControlProblem(disc(), 10, q_start=A, q_goal=A + 2 * B, v_start=[None] * 3,
                                         v_goal=[None] * 3, duration=(2.0, 3.0))
    guess = from_waypoints(problem, [A, A + 2 * B])
    assert guess.h == 0.2
    np.testing.assert_allclose(guess.t, 0.2 * np.arange(11), rtol=0, atol=1e-15)
    np.testing.assert_allclose(guess.q, A + np.outer(guess.t, B), rtol=0, atol=1e-14)
    np.testing.assert_allclose(guess.p, np.tile(M * B, (11, 1)), rtol=0, atol=1e-14)
