"""The status vocabulary (`dmoc.Status`): members equal to the strings results carried
before the enumeration, one message each, JSON and result files written as plain strings
and read back as members. Oracle: the literal strings of the released file format."""

import dataclasses
import json

import numpy as np
import pytest

import dmoc
from dmoc.errors import MESSAGES, Status, status_of

# The statuses dmoc wrote as plain strings before the enumeration (issue 39), the
# simulator's success status, and the verdict on SO(3)'s missed goal (issue 43).
STRINGS = ["converged", "newton_failed", "non_finite", "interrupted", "passed", "not_replayable",
           "path_violated", "under_resolved", "accuracy_not_reached", "timeout", "worker_lost",
           "exception", "undeserializable", "scheduler_lost", "goal_missed"]


@pytest.mark.parametrize("text", STRINGS)
def test_each_member_equals_its_string(text):
    member = Status(text)
    assert member == text and text == member
    assert str(member) == text and f"{member}" == text
    assert json.dumps({"status": member}) == json.dumps({"status": text})


def test_the_enumeration_is_the_strings_and_nothing_else():
    assert sorted(s.value for s in Status) == sorted(STRINGS)


@pytest.mark.parametrize("member", list(Status))
def test_each_member_has_its_message(member):
    assert set(MESSAGES) == set(Status)
    assert isinstance(member.message, str) and member.message


def test_ipopt_statuses_stay_plain_strings():
    assert status_of("Solve_Succeeded") == "Solve_Succeeded"
    assert type(status_of("Solve_Succeeded")) is str
    assert status_of("path_violated") is Status.PATH_VIOLATED


def test_a_simulation_reports_a_member():
    s = dmoc.systems.knife_edge()
    result = dmoc.simulate(dmoc.discretize(s, 0.1), q0=np.zeros(3), v0=np.zeros(3), steps=5,
                           controls=np.zeros((5, 2)))
    assert result.status is Status.CONVERGED


def test_a_result_file_holds_plain_strings_and_loads_members(tmp_path):
    problem = dmoc.problems.knife_edge_parking(40)
    result = dmoc.optimize(problem)
    path = tmp_path / "result.npz"
    result.save(path)
    with np.load(path) as raw:
        stored = {k: raw[k] for k in raw.files}
    status = next(v for k, v in stored.items() if k.endswith("status"))
    assert status.dtype.kind == "U" and str(status) == str(result.status)
    verdict = json.loads(str(next(v for k, v in stored.items() if k.endswith("verdict"))))
    assert type(verdict["status"]) is str and verdict["status"] == "passed"
    loaded = dmoc.OptimizationResult.load(path)
    assert loaded.verdict.status is Status.PASSED
    assert loaded.status == result.status


def test_an_old_file_with_string_statuses_loads(tmp_path):
    """A file as written before the enumeration: every status a plain string."""
    result = dmoc.optimize(dmoc.problems.knife_edge_parking(40))
    verdict = dmoc.Verdict(**dict(result.verdict.as_dict(), status="under_resolved"))
    old = dataclasses.replace(result, success=False, status="under_resolved", verdict=verdict)
    assert type(old.status) is str and type(old.verdict.status) is str
    path = tmp_path / "old.npz"
    old.save(path)
    loaded = dmoc.OptimizationResult.load(path)
    assert loaded.status is Status.UNDER_RESOLVED and loaded.status == "under_resolved"
    assert loaded.verdict.status is Status.UNDER_RESOLVED
    assert not loaded.verdict.passed
