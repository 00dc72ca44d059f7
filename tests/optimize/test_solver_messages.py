"""What optimize() says when IPOPT cannot be run or stops: options of the wrong kind and
options IPOPT rejects are named on the first line, a non-finite start names the value,
an absurd step names the most violated group, and a solve stopped at its iteration limit
keeps its last iterate.

Oracles, none taken from the code under test: IPOPT's own status and iteration count;
the messages by content; the saved iterate must come back bit for bit."""

import sys
import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import batch
from dmoc.problems import knife_edge_parking
from dmoc.systems import knife_edge

from tests._helpers import problem, same

H, N = 0.1, 6


@pytest.mark.parametrize("options, error, words", [
    ({"max_iter": None}, TypeError, r"`options\['max_iter'\]`"),
    ({3: 1}, TypeError, "string keys"),
])
def test_options_of_the_wrong_kind_are_named(disc, options, error, words):
    with pytest.raises(error, match=words):
        dmoc.optimize(problem(disc), options=options)


@pytest.mark.parametrize("options, name", [({"max_iter": "many"}, "max_iter"),
                                           ({"mu_strategy": "nonsense"}, "mu_strategy")])
def test_rejected_option_is_named_on_the_first_line(disc, options, name, capfd):
    with pytest.raises(ValueError) as info:
        dmoc.optimize(problem(disc), options=options)
    capfd.readouterr()
    assert name in str(info.value).splitlines()[0]


def test_invalid_option_at_solve_time_reports_this_solve(disc, capfd, monkeypatch):
    """An HSL solver that IPOPT lacks, past dmoc's own check (which refuses it before)."""
    monkeypatch.setattr(sys.modules["dmoc.optimal_control.solver.solving"], "check_linear_solver", lambda o: None)
    dmoc.optimize(problem(disc), options={"max_iter": 3}, throw=False)
    result = dmoc.optimize(problem(disc), options={"linear_solver": "ma57"}, throw=False)
    capfd.readouterr()
    assert result.status == "Invalid_Option"
    assert result.stats["iterations"] == 0 and "after 3 iterations" not in result.message


def test_invalid_number_names_the_non_finite_value(capfd):
    """A cost that is NaN at the start point (log of a negative number)."""
    result = dmoc.optimize(dmoc.OptimalControlProblem(
        dmoc.discretize(knife_edge(), 0.1), 5, q_start=[0, 0, 0], q_goal=[0, 0.1, 0],
        running_cost=lambda q, v, u: ca.sumsqr(u) + ca.log(q[0] - 1)), throw=False)
    capfd.readouterr()
    assert result.status == "Invalid_Number_Detected"
    assert "0.00e+00" not in result.message and ("NaN" in result.message or "Inf" in result.message)


def test_absurd_step_fails_naming_the_violation(capfd):
    """h = 1e-302: 1/h is finite but the rows are of order 1e300; IPOPT stops and the
    message names the most violated group and its size."""
    tiny = dmoc.discretize(knife_edge(), 1e-302)
    result = dmoc.optimize(dmoc.OptimalControlProblem(tiny, 5, q_start=[0, 0, 0],
                                                      q_goal=[0, 0.1, 0]), throw=False)
    capfd.readouterr()
    assert not result.success
    assert "most violated" in result.message and "e+30" in result.message


def test_expand_option_must_be_boolean():
    with pytest.raises(TypeError, match="expand"):
        dmoc.optimize(knife_edge_parking(10), expand="no")


def test_iteration_limit_keeps_the_last_iterate(disc, tmp_path):
    problem = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.SolverError, match="Maximum_Iterations_Exceeded after 3 iterations") as info:
        dmoc.optimize(problem, options={"max_iter": 3}, check=False)
    result = info.value.result
    assert result.success is False and result.stats["iterations"] == 3
    x = problem.x_layout
    np.testing.assert_array_equal(result.trajectory.q, x.unpack(result.x, "q").T)
    assert np.isfinite(result.trajectory.q).all() and result.trajectory.steps == 10
    result.trajectory.save(tmp_path / "last.npz")
    assert same(dmoc.Trajectory.load(tmp_path / "last.npz"), result.trajectory)
    # The last iterate is a warm start that finishes the job.
    assert dmoc.optimize(problem, guess=result.trajectory, check=False).success


def test_unknown_options_are_rejected_by_dmoc(capfd):
    """In place of a test of Python's keyword check: dmoc's own checks reject an unknown
    key of a batch run and an option IPOPT does not know, naming it."""
    disc = dmoc.discretize(knife_edge(), H)
    with pytest.raises(dmoc.InputError, match=r"`runs\[0\]` has unknown keys \['tolerance'\]"):
        batch.simulate_many(disc, [{"q0": [0, 0, 0], "v0": [1, 0, 0], "steps": 2,
                                    "tolerance": 1e-9}], client="tcp://127.0.0.1:1")
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(ValueError, match=r"(?s)`options`.*No such IPOPT option: tolerance"):
        dmoc.optimize(problem, options={"tolerance": 1e-9})
    capfd.readouterr()
