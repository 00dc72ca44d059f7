"""A stage rule from the default guess starts from the midpoint rule's optimum
(`dmoc.drivers.high_order`, issue 40): the start is recorded, the optimum replays and its
cost agrees with the midpoint rule's Richardson limit; a given guess is taken as it is."""

import dataclasses

import numpy as np
import pytest

import dmoc
import dmoc.problems as P

from dmoc.drivers import high_order
from dmoc.drivers.high_order import equality_constrained
from dmoc.drivers.verdict import judged_solve, verdict_message
from dmoc.errors import Status

from .hard_problems import bounded_disk, truck_bay


def test_with_rule_keeps_the_statement():
    problem = P.knife_edge_parking(12, rule="lobatto3")
    midpoint = problem.with_rule("midpoint")
    assert (midpoint.disc.rule.name, midpoint.steps, midpoint.disc.h) == ("midpoint", 12, problem.disc.h)
    assert midpoint.structure != problem.structure
    assert np.array_equal(midpoint.q_goal, problem.q_goal)


@pytest.fixture(scope="module")
def disk_limit():
    """The midpoint rule's Richardson limit of the bounded disk's cost (N = 80, 160: its
    error ~ 1e-5, bang-bang arcs), and the spread of the last two extrapolations."""
    J = [dmoc.optimize(bounded_disk(N)).cost for N in (40, 80, 160)]
    limits = [J[1] + (J[1] - J[0]) / 3, J[2] + (J[2] - J[1]) / 3]
    return limits[1], abs(limits[1] - limits[0])


@pytest.mark.parametrize("rule", ["lobatto3", "lobatto4"])
def test_stage_rule_starts_from_the_midpoint_optimum(rule, disk_limit):
    result = dmoc.optimize(bounded_disk(20, rule))
    start = result.stats["start"]
    assert (start["rule"], start["status"]) == ("midpoint", "Solve_Succeeded")
    assert result.verdict.passed and result.verdict.replay_q <= 1e-8
    limit, spread = disk_limit
    # the midpoint rule's own error at N = 20 is 2e-3; the stage rules' within its limit's spread
    assert abs(result.cost - limit) <= 3 * spread + 2e-5
    # the same optimum as IPOPT's from the default guess, which lands right on this problem
    plain = judged_solve(bounded_disk(20, rule))
    assert plain.verdict.passed and abs(plain.cost - result.cost) <= 1e-9 * plain.cost


def test_stage_rule_start_is_cheap():
    """The stage rule's solve from the midpoint optimum takes few iterations (its barrier
    starts small, `STARTED_OPTIONS`): 13 on the disk against 21-30 from the default guess."""
    result = dmoc.optimize(bounded_disk(20, "lobatto4"))
    assert result.stats["iterations"] <= 15


def test_midpoint_and_given_guess_start_as_before():
    assert dmoc.optimize(bounded_disk(20)).stats.get("start") is None
    first = dmoc.optimize(bounded_disk(20, "lobatto3"))
    again = dmoc.optimize(bounded_disk(20, "lobatto3"), guess=first.trajectory)
    assert again.stats.get("start") is None


def test_truck_backing_a_trailer_replays():
    """The truck backing a trailer into a bay, lobatto3 at N = 30 from the default guess:
    started from the midpoint optimum, it replays (its root is the simulator's), its final
    time and cost within the rules' difference of the midpoint optimum's. Its steering
    rate, a path row imposed between the knots, exceeds 0.4 rad/s at the knots (issue 40's
    rate bounds): the verdict says ``path_violated``, not ``not_replayable``."""
    midpoint = dmoc.optimize(truck_bay(30))
    result = dmoc.optimize(truck_bay(30, "lobatto3"), throw=False)
    assert result.stats["start"]["iterations"] == midpoint.stats["iterations"]
    assert result.verdict.replay_q <= 1e-8 and result.verdict.replay_p <= 1e-8
    assert result.status != Status.NOT_REPLAYABLE
    assert abs(result.trajectory.t[-1] - midpoint.trajectory.t[-1]) < 0.05 * midpoint.trajectory.t[-1]
    assert abs(result.cost - midpoint.cost) < 0.02 * midpoint.cost
    assert result.stats["iterations"] <= 30


def test_not_replayable_message_names_the_remedy():
    result = dmoc.optimize(P.knife_edge_parking(10, rule="lobatto3"))
    failed = dataclasses.replace(result.verdict, status=Status.NOT_REPLAYABLE, replay_q=0.3,
                                 replay_p=0.2, replay_step=1)
    message = verdict_message(failed, result)
    assert 'guess=dmoc.optimize(problem.with_rule("midpoint").with_steps(20))' in message
    midpoint = dmoc.optimize(P.knife_edge_parking(10), throw=False)
    assert "with_rule" not in verdict_message(failed, midpoint)


def test_accuracy_target_starts_its_first_level_so():
    result = dmoc.optimize(bounded_disk(10, "lobatto3"), accuracy=1e-3)
    levels = result.stats["levels"]
    assert levels[0]["start"]["rule"] == "midpoint"
    assert all(level["start"] is None for level in levels[1:])


@pytest.mark.parametrize("make, rule, steps", [(P.knife_edge_parking, "lobatto4", 14),
                                               (P.rolling_disk_steering, "lobatto3", 31)])
def test_an_equality_constrained_stage_rule_starts_from_the_default_guess(make, rule, steps):
    """Without inequalities the verdict is what catches another root of the step
    equations: the stage rule is solved from the default guess, no midpoint solve spent,
    and lands on the optimum the midpoint start reaches."""
    problem = make(steps, rule=rule)
    assert equality_constrained(problem)
    result = dmoc.optimize(problem)
    assert result.verdict.passed and result.stats.get("start") is None
    midpoint = dmoc.optimize(problem.with_rule("midpoint"))
    started = judged_solve(problem, guess=midpoint.trajectory)
    assert abs(result.cost - started.cost) <= 1e-9 * started.cost
    np.testing.assert_allclose(result.trajectory.q, started.trajectory.q, rtol=0, atol=1e-7)
    assert not equality_constrained(bounded_disk(10, rule))                 # bounds, free time
    assert not equality_constrained(dmoc.OptimalControlProblem(             # free time alone
        problem.disc, steps, q_start=problem.q_start, duration=(1.0, 8.0),
        q_goal=[None if np.isnan(g) else g for g in problem.q_goal]))


def test_an_equality_constrained_stage_rule_that_fails_takes_the_midpoint_start(monkeypatch):
    """When the solve from the default guess fails (here made to: its verdict replaced by
    not_replayable), the midpoint optimum starts a second solve, and the record says why."""
    calls = []

    def refused_once(problem, **keywords):
        result = judged_solve(problem, **keywords)
        calls.append(keywords.get("guess"))
        if len(calls) == 1:
            return dataclasses.replace(result, success=False, status=Status.NOT_REPLAYABLE)
        return result
    monkeypatch.setattr(high_order, "judged_solve", refused_once)
    result = high_order.started_solve(P.knife_edge_parking(14, rule="lobatto4"))
    assert result.success and calls[0] is None and calls[1] is not None
    assert (result.stats["start"]["rule"], result.stats["start"]["after"]) == ("midpoint", "not_replayable")
