"""`velocity_bounds`: checked as the other bounds are, refused where given boundary
velocities break them, carried by every copy of a problem, named in the NLP's rows, the
verdict and result files.

Oracles: the values written in the tests (bounds, velocities), and an optimum judged
against a bound it was not solved with, whose knot velocities (the mean of the two step
velocities, written here for the midpoint rule) exceed it.
"""

import numpy as np
import pytest

import dmoc
from dmoc.drivers.verdict import judge, verdict_message
from dmoc.optimal_control.solver.violation import described

RATE = 0.6


def parking(steps=10, rule="midpoint", **changes):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / steps, rule)
    data = {"q_start": [0, 0, 0], "q_goal": [0, 1, 0],
            "velocity_bounds": ([None, None, -RATE], [None, None, RATE]), **changes}
    return dmoc.OptimalControlProblem(disc, steps, **data)


@pytest.mark.parametrize("bounds, match", [
    ([0, 0, 0], r"`velocity_bounds` must be a pair \(lower, upper\) of arrays of shape \(3,\)"),
    (([0, 0], [1, 1]), r"`velocity_bounds`.*shape \(3,\)"),
    (([0, 0, 1], [1, 1, 0]), r"`velocity_bounds` must satisfy lower <= upper"),
])
def test_bad_velocity_bounds_are_refused_naming_the_argument(bounds, match):
    with pytest.raises(dmoc.InputError, match=match):
        parking(velocity_bounds=bounds)


@pytest.mark.parametrize("end, value", [("v_start", [0.0, 0.0, 0.7]), ("v_goal", [0.0, 0.0, -0.9])])
def test_a_given_boundary_velocity_outside_the_bounds_is_refused(end, value):
    bound = RATE if value[2] > 0 else -RATE
    relation = ">" if value[2] > 0 else "<"
    with pytest.raises(dmoc.InputError, match=rf"`{end}` must lie within `velocity_bounds`; "
                                              rf"{end}\[2\] \(theta\) = {value[2]:g} {relation} {bound:g}"):
        parking(**{end: value})
    with pytest.raises(dmoc.InputError, match=rf"`{end}` must lie within `velocity_bounds`"):
        parking().with_boundary(**{end: value})


def test_rest_outside_the_bounds_is_refused():
    """The default ends are at rest: a bound that excludes v = 0 refuses them."""
    with pytest.raises(dmoc.InputError, match=r"`v_start` must lie within `velocity_bounds`; "
                                              r"v_start\[0\] \(x\) = 0 < 0.1"):
        parking(velocity_bounds=([0.1, None, None], [None, None, None]))


def test_the_rows_and_the_free_boundary_velocities_carry_the_bounds():
    """Midpoint: one row per step (its step velocity), none at the knots (each the mean of
    two bounded step velocities); lobatto4: one per stage node and one per knot; a free
    goal velocity is bounded in x."""
    mid, lob = parking(), parking(rule="lobatto4", v_goal=[None, None, None])
    assert mid.g_layout.blocks["velocity_steps"][1:] == (1, 10)
    assert mid.g_layout.blocks["velocity_knots"][1:] == (0, 11)
    assert lob.g_layout.blocks["velocity_steps"][1:] == (2, 10)
    assert lob.g_layout.blocks["velocity_knots"][1:] == (1, 11)
    for problem in (mid, lob):
        for name in ("velocity_steps", "velocity_knots"):
            assert (problem.g_layout.unpack(problem.lbg, name) == -RATE).all()
            assert (problem.g_layout.unpack(problem.ubg, name) == RATE).all()
    goal = lob.x_layout.unpack(lob.lbx * 1.0, "v_goal")[:, 0], lob.x_layout.unpack(lob.ubx * 1.0, "v_goal")[:, 0]
    np.testing.assert_array_equal(goal[0], [-np.inf, -np.inf, -RATE])
    np.testing.assert_array_equal(goal[1], [np.inf, np.inf, RATE])


def test_every_copy_keeps_the_bounds():
    problem = parking()
    copies = [problem.with_boundary(q_goal=[0.1, 1, 0]), problem.with_steps(20), problem.with_rule("lobatto3"),
              dmoc.MPC(problem).problem]
    for copy in copies:
        assert copy.velocity_bounds[1][2] == RATE and copy.velocity_bounded == (2,)
        assert copy.g_layout.numel("velocity_steps") > 0
    assert copies[0].structure == problem.structure
    assert dmoc.MPC(problem).problem.structure != problem.structure    # a start momentum instead


def test_the_verdict_names_a_violated_bound_and_its_knot():
    """An optimum of the unbounded parking judged against |theta'| <= 0.6: its knot rates
    (the mean of the step velocities around each knot, computed here) exceed 0.6, and the
    verdict names the bound, the knot of the largest excess and the result file keeps it."""
    free = dmoc.optimize(parking(20, velocity_bounds=None))
    q, h = free.trajectory.q, free.trajectory.h
    steps = np.diff(q[:, 2]) / h
    knots = np.concatenate([steps[:1], (steps[1:] + steps[:-1]) / 2, steps[-1:]])
    rows = {"lower": -knots - RATE, "upper": knots - RATE}      # g <= 0, each over its scale
    relative = {side: g / max(1.0, np.abs(g).max()) for side, g in rows.items()}
    side = max(relative, key=lambda side: relative[side].max())
    verdict = judge(parking(20), free)
    assert verdict.status == "path_violated" and verdict.path_row == -1
    assert verdict.path_step == int(np.argmax(relative[side]))
    assert verdict.path_violation == pytest.approx(relative[side].max(), rel=1e-12) and verdict.path_violation > 0.1
    assert verdict.path_limit == f"velocity_bounds {side} of theta (v[2] {'<=' if side == 'upper' else '>='} " \
                                 f"{RATE if side == 'upper' else -RATE:g})"
    assert f"{verdict.path_limit} is violated at knot {verdict.path_step}" in verdict_message(verdict, free)
    assert dmoc.Verdict.from_dict(verdict.as_dict()) == verdict
    old = {k: v for k, v in verdict.as_dict().items() if k != "path_limit"}
    assert dmoc.Verdict.checked({**old, "status": "path_violated"}).path_limit == ""


def test_the_rows_are_named_by_their_limit_entry_and_place():
    """`stats["most_violated"]` names a velocity row by its entry and knot or step (and the
    step's interior point where there are several), a path row by its row and point."""
    problem = parking(rule="lobatto4", path_constraints=lambda q, v, u: q[0] - 5.0)
    G = problem.g_layout
    row = {name: G.slice(name).start for name in ("velocity_knots", "velocity_steps", "path")}
    assert described(problem.transcription, row["velocity_knots"] + 3) == "velocity bound of v[2] at knot 3"
    assert described(problem.transcription, row["velocity_steps"] + 2 * 4 + 1) == \
        "velocity bound of v[2] at step 4 (point 1)"
    assert described(problem.transcription, row["path"] + 2 * 4 + 1) == "path constraint 0 at step 4 (point 1)"
    midpoint = parking(path_constraints=lambda q, v, u: q[0] - 5.0)
    rows = {name: midpoint.g_layout.slice(name).start + 4 for name in ("path", "velocity_steps")}
    assert described(midpoint.transcription, rows["path"]) == "path constraint 0 at step 4"
    assert described(midpoint.transcription, rows["velocity_steps"]) == "velocity bound of v[2] at step 4"
