"""Path constraints hold at every knot q_0 ... q_N as well as at the steps' midpoints, and
an end that violates one of q alone is refused before the solve.

Oracles, none taken from the code under test:
- the disc obstacle's closed form |(x, y) - c| >= rho, evaluated here at every knot and at
  every chord midpoint (q_k + q_{k+1}) / 2 of the returned trajectory;
- the disc's value rho^2 - |q - c|^2 at the given ends, computed here;
- a goal forced into the disc by a state bound has no feasible point: IPOPT must say so
  (before, with the constraint at the midpoints only, it was "solved").
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.systems import differential_drive

CENTRE, RHO = np.array([1.0, 0.05]), 0.3


def outside_disc(q, v, u, w=None):
    """g <= 0 outside the disc of radius RHO about `CENTRE` (or about w["c"])."""
    centre = CENTRE if w is None else w["c"]
    return RHO ** 2 - ca.sumsqr(q[:2] - centre)


def drive(steps, rule="midpoint", **changes):
    """The differential drive from rest at the origin to rest at (2, 0), heading 0, wheel
    angles free at the goal, in 4 s, past the disc in its way."""
    disc = dmoc.discretize(differential_drive(), 4.0 / steps, rule)
    data = {"q_start": [0, 0, 0, 0, 0], "q_goal": [2.0, 0, 0, None, None],
            "path_constraints": outside_disc, **changes}
    return dmoc.OptimalControlProblem(disc, steps, **data)


def distances(q):
    """|(x, y) - c| at the knots and at the chord midpoints, shapes (N+1,) and (N,)."""
    xy = q[:, :2] - CENTRE
    return np.linalg.norm(xy, axis=1), np.linalg.norm((xy[1:] + xy[:-1]) / 2, axis=1)


@pytest.mark.parametrize("steps, rule", [(12, "midpoint"), (40, "midpoint"), (12, "lobatto3")])
def test_no_knot_of_the_differential_drive_enters_the_disc(steps, rule):
    """Every knot keeps its distance rho from the centre to 1e-9 (before, with the
    constraint at the midpoints only, knots cut in by 1e-3 to 2e-2), and the constraint is
    active somewhere."""
    result = dmoc.optimize(drive(steps, rule))
    knots, mid = distances(result.trajectory.q)
    assert knots.min() >= RHO - 1e-9
    if rule == "midpoint":                  # the midpoint rule's interpolant is the chord
        assert mid.min() >= RHO - 1e-9
    assert min(knots.min(), mid.min()) <= RHO + 1e-6


@pytest.mark.parametrize("end, value", [("q_goal", [1.1, 0.1, 0, None, None]),
                                        ("q_start", [0.9, 0.0, 0, 0, 0])])
def test_an_end_inside_the_disc_is_refused_naming_the_end(end, value):
    g = RHO ** 2 - np.sum((np.array(value[:2]) - CENTRE) ** 2)
    with pytest.raises(dmoc.InputError, match=rf"`{end}` must satisfy `path_constraints` .*g\[0\] = "
                                              rf"{g:.6g} there"):
        drive(12, **{end: value})


@pytest.mark.parametrize("depth", [1e-3, 1e-6])
def test_an_end_barely_inside_the_disc_is_refused(depth):
    """A goal where rho^2 - |q - c|^2 = `depth` (computed here): far below the disc's size
    but above IPOPT's constraint tolerance (1e-10), so no solution holds the row there."""
    goal = [CENTRE[0] + np.sqrt(RHO ** 2 - depth), CENTRE[1], 0, None, None]
    g = RHO ** 2 - np.sum((np.array(goal[:2]) - CENTRE) ** 2)
    assert g == pytest.approx(depth, rel=1e-6)
    with pytest.raises(dmoc.InputError, match=rf"`q_goal` must satisfy .*g\[0\] = {g:.6g} there"):
        drive(12, q_goal=goal)


def test_an_end_on_the_disc_within_round_off_is_accepted():
    """A goal on the circle, rho^2 - |q - c|^2 of round-off size (below 1e-10): allowed."""
    goal = [CENTRE[0] + RHO, CENTRE[1], 0, None, None]
    assert abs(RHO ** 2 - np.sum((np.array(goal[:2]) - CENTRE) ** 2)) < 1e-15
    assert drive(12, q_goal=goal).steps == 12


def test_new_data_that_put_an_end_inside_the_disc_are_refused():
    """with_boundary (a goal inside) and with_parameters (the disc moved onto the goal)."""
    problem = drive(12, path_constraints=outside_disc, parameters={"c": CENTRE})
    with pytest.raises(dmoc.InputError, match="`q_goal` must satisfy"):
        problem.with_boundary(q_goal=[1.0, 0.2, 0, None, None])
    with pytest.raises(dmoc.InputError, match="`q_goal` must satisfy"):
        problem.with_parameters(c=[2.0, 0.1])


def test_rows_that_read_a_free_entry_are_not_judged_before_the_solve():
    """x free at the goal: the disc row is not evaluated there (no refusal)."""
    drive(12, q_goal=[None, 0.05, 0, None, None])


def test_rows_that_read_v_or_u_are_held_at_the_knots_too_but_not_judged_at_a_given_end():
    """A speed limit and a torque limit (rows 1 and 2) are imposed at the knots with the
    knot velocity and control, as the disc (row 0) is (tests/optimize/test_knot_rates.py
    checks their values). A start that breaks the speed limit's formula with v = 0 is not
    refused (the knot velocity at a given end is the solve's); a start inside the disc is,
    naming the user's row 1."""
    problem = drive(12, path_constraints=lambda q, v, u: ca.vertcat(
        outside_disc(q, v, u), v[0] - 1.0, u[0] - 5.0))
    assert problem.g_layout.blocks["path"][1:] == (3, 12)
    assert problem.g_layout.blocks["path_knots"][1:] == (3, 13)
    drive(12, path_constraints=lambda q, v, u: 1.0 - v[0] - ca.sumsqr(q[:2]))
    with pytest.raises(dmoc.InputError, match=r"`q_start` must satisfy .*got g\[1\] = "):
        drive(12, q_start=[1.0, 0.0, 0, 0, 0],
              path_constraints=lambda q, v, u: ca.vertcat(v[0] - 1.0, outside_disc(q, v, u)))


def test_a_goal_forced_into_the_disc_is_reported_infeasible_at_a_knot():
    """x = 1 at the goal and |y| <= 0.2 put the goal inside the disc with y free: IPOPT
    detects the infeasibility, and the most violated row is the disc's (row 1 of the
    user's, after a speed limit) at the goal knot."""
    problem = drive(12, q_goal=[1.0, None, 0, None, None],
                    state_bounds=([None, -0.2, None, None, None], [None, 0.2, None, None, None]),
                    path_constraints=lambda q, v, u: ca.vertcat(v[0] - 10.0, outside_disc(q, v, u)))
    result = dmoc.optimize(problem, throw=False)
    assert not result.success and result.status == "Infeasible_Problem_Detected"
    assert result.stats["most_violated"].startswith("path constraint 1 at knot 12")
