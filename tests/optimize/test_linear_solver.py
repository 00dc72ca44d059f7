"""The linear-solver report of `dmoc.optimize` (``linear_solver_report=True``,
`dmoc.linear_solver`): read from IPOPT's detailed journal, one solve at a time, without
changing the solve.

Oracles: journal lines in IPOPT's wording written here; the same solve without the report;
IPOPT's per-iteration regularization in CasADi's own stats (each regularized iteration
needs at least one more factorization). The journals are looked for in a temporary folder
of the test's own, so that other test processes' journals do not count.
"""

import glob
import os
import subprocess
import sys
import tempfile

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc.mechanics.robots import example_urdf
from dmoc.optimal_control.solver.linear_solver import linear_solver_report

REPORT = {"linear_solver_report": True}


def test_report_counts_the_lines_of_one_solve(tmp_path):
    """A journal of two solves, read from the start of the second: only its lines count."""
    earlier = "Number of trial factorizations performed: 4\nIterative refinement failed with residual_ratio = 1e-3\n"
    later = ("Number of trial factorizations performed: 1\n"
             "Iterative refinement failed with residual_ratio = 8.127344e-07\n"
             "Asking augmented system solver to improve quality of its solutions.\n"
             "Increasing pivot tolerance for MUMPS from 1.00e-06 to 1.00e-03.\n"
             "Number of trial factorizations performed: 3\n"
             "Iterative refinement failed with residual_ratio = 2.0e-07\n"
             "Iterative refinement failed with residual_ratio = 3.0e-07\n"
             "Increasing pivot tolerance for MUMPS from 1.00e-03 to 1.00e-02.\n"
             "Number of trial factorizations performed: 1\n"
             "MUMPS returned INFO(1) = -9 and requires more memory, reallocating.  Attempt 1\n"
             "  Increasing icntl[13] from 1 to 2.\n"
             "MUMPS returned INFO(1) = -9 and requires more memory, reallocating.  Attempt 2\n"
             "  Increasing icntl[13] from 2 to 4.\n")
    path = tmp_path / "journal.txt"
    path.write_text(earlier + later)
    assert linear_solver_report(str(path), len(earlier.encode())) == {
        "factorizations": 5, "pivot_tolerance_increases": 2, "pivot_tolerance": 1e-2,
        "refinement_failures": 3, "reallocations": 2}
    assert linear_solver_report(str(path), 0)["factorizations"] == 9


@pytest.mark.parametrize("make", [dmoc.problems.knife_edge_parking, dmoc.problems.rolling_disk_steering])
def test_report_leaves_the_solve_unchanged_and_counts_each_solve(make):
    problem = make(50)
    plain = dmoc.optimize(problem, reuse_solver=False)
    first = dmoc.optimize(problem, **REPORT)
    again = dmoc.optimize(problem, **REPORT)          # the same solver: appended journal
    assert again.stats["solver_reused"] and again.stats["iterations"] == first.stats["iterations"]
    assert first.cost == plain.cost and first.stats["iterations"] == plain.stats["iterations"]
    report = first.stats["linear_solver"]
    assert report["factorizations"] >= first.stats["iterations"] + first.stats["regularized_iterations"]
    if first.stats["regularized_iterations"] == 0:
        assert report["factorizations"] == first.stats["iterations"]
    assert again.stats["linear_solver"] == report
    assert "linear_solver" not in plain.stats


def test_default_workspace_needs_no_reallocation():
    """MUMPS's workspace at `DEFAULT_IPOPT_OPTIONS`' mumps_mem_percent 100 (twice its
    estimate) suffices; at 1 % MUMPS stops twice for more (IPOPT doubles 1 to 2 to 4) and
    the solve is the same. The knife edge with lobatto3 at N = 50, whose pivots need more
    than the estimate."""
    problem = dmoc.problems.knife_edge_parking(50, rule="lobatto3")
    default = dmoc.optimize(problem, check=False, **REPORT)
    scarce = dmoc.optimize(problem, check=False, options={"mumps_mem_percent": 1}, **REPORT)
    assert default.stats["linear_solver"]["reallocations"] == 0
    assert scarce.stats["linear_solver"]["reallocations"] == 2
    assert scarce.cost == default.cost and scarce.stats["iterations"] == default.stats["iterations"]
    assert (scarce.x == default.x).all()


def test_a_robot_with_path_rows_needs_no_reallocation_either():
    """A KKT structure other than the parking problems': the six-joint arm's rest-to-rest
    DMOC (N = 20, dense 6 x 6 blocks of M(q), 13 path rows a knot: joint speeds and the
    tool's height). At the default the workspace suffices; IPOPT's own 1000 % and a
    scarce 1 % (two reallocations) give the same iterates bit for bit."""
    pytest.importorskip("adam.casadi", reason="the robots extra is not installed")
    arm = dmoc.RobotSystem(example_urdf("arm6"))
    tool = arm.link_position("tool")
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(arm, 0.05), 20, q_start=[0.0, -0.5, 1.0, -0.5, 0.0, 0.0],
        q_goal=[0.5, -0.8, 1.2, -0.3, 0.3, 0.2], v_start=np.zeros(6), v_goal=np.zeros(6),
        control_bounds=arm.effort_limits, state_bounds=arm.position_limits,
        running_cost=lambda q, v, u: ca.sumsqr(u) + 10 * ca.sumsqr(v),
        path_constraints=lambda q, v, u: ca.vertcat(v - 1.0, -v - 1.0, 0.05 - tool(q)[2]))
    default = dmoc.optimize(problem, check=False, **REPORT)
    assert default.success and default.stats["linear_solver"]["reallocations"] == 0
    for percent, reallocations in ((1000, 0), (1, 2)):
        other = dmoc.optimize(problem, check=False, options={"mumps_mem_percent": percent}, **REPORT)
        assert other.stats["linear_solver"]["reallocations"] == reallocations
        assert other.stats["iterations"] == default.stats["iterations"] and (other.x == default.x).all()


def test_report_refuses_an_output_file_of_the_users(tmp_path):
    with pytest.raises(ValueError, match="output_file"):
        dmoc.optimize(dmoc.problems.knife_edge_parking(10),
                      options={"output_file": str(tmp_path / "mine.txt")}, **REPORT)


def test_journal_file_is_removed_when_the_process_ends(tmp_path):
    script = ("import glob, os, tempfile, dmoc, dmoc.problems\n"
              "before = set(glob.glob(os.path.join(tempfile.gettempdir(), 'dmoc-ipopt-*.txt')))\n"
              "dmoc.optimize(dmoc.problems.knife_edge_parking(10), linear_solver_report=True, check=False)\n"
              "(path,) = set(glob.glob(os.path.join(tempfile.gettempdir(), 'dmoc-ipopt-*.txt'))) - before\n"
              "assert os.path.getsize(path) > 0\n"
              "print(path)\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                         env={**os.environ, "TMPDIR": str(tmp_path)})
    path = out.stdout.strip().splitlines()[-1]
    assert path.endswith(".txt")
    assert not os.path.exists(path)


def test_a_fresh_solver_leaves_the_journal_of_the_cached_one():
    """A solver built with reuse_solver=False, or with expand=True, between two solves of
    the cached one has a journal of its own (tests from a review of the change)."""
    problem = dmoc.problems.knife_edge_parking(50)
    first = dmoc.optimize(problem, **REPORT)
    far = problem.with_boundary(q_goal=[10, 10, -12.0])
    for other in ({"reuse_solver": False}, {"expand": True}):
        dmoc.optimize(far, **REPORT, **other, throw=False)
        again = dmoc.optimize(problem, **REPORT)
        assert again.stats["solver_reused"]
        assert again.stats["linear_solver"] == first.stats["linear_solver"]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_forked_child_leaves_the_parents_journal():
    problem = dmoc.problems.knife_edge_parking(20)
    dmoc.optimize(problem, **REPORT)
    pid = os.fork()
    if pid == 0:                    # the child ends through the interpreter's exit handlers
        import atexit
        atexit._run_exitfuncs()
        os._exit(0)
    os.waitpid(pid, 0)
    assert dmoc.optimize(problem, **REPORT).stats["linear_solver"]["factorizations"] > 0


@pytest.mark.parametrize("report_first", [True, False])
def test_report_is_given_exactly_when_asked_for(report_first, monkeypatch):
    """A solver built without the report (even with file_print_level 6 and no output file,
    where IPOPT writes nothing) is not the one a reported solve takes, nor the reverse
    (second review of the change)."""
    dmoc.clear_caches("solvers")
    problem = dmoc.problems.knife_edge_parking(20)
    reported, plain = REPORT, {"options": {"file_print_level": 6}}
    for keywords in ([reported, plain] if report_first else [plain, reported]):
        stats = dmoc.optimize(problem, **keywords).stats
        assert ("linear_solver" in stats) == (keywords is reported)


def test_the_journal_of_an_evicted_solver_goes_with_it(monkeypatch, tmp_path):
    """A cache of one solver: the second structure's solver evicts the first, and the
    first's journal goes with it."""
    from dmoc.optimal_control.solver import ipopt
    monkeypatch.setattr(ipopt, "_SOLVERS", type(ipopt._SOLVERS)(1, "solvers"))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    pattern = os.path.join(tempfile.gettempdir(), "dmoc-ipopt-*.txt")
    before = set(glob.glob(pattern))
    dmoc.optimize(dmoc.problems.knife_edge_parking(10), **REPORT, check=False)
    (first,) = set(glob.glob(pattern)) - before
    dmoc.optimize(dmoc.problems.knife_edge_parking(12), **REPORT, check=False)
    assert not os.path.exists(first) and len(set(glob.glob(pattern)) - before) == 1


def test_the_journal_of_a_solver_not_kept_goes_with_it(monkeypatch, tmp_path):
    """reuse_solver=False: the solver is dropped after the call, and its journal with it."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    pattern = os.path.join(tempfile.gettempdir(), "dmoc-ipopt-*.txt")
    before = set(glob.glob(pattern))
    result = dmoc.optimize(dmoc.problems.knife_edge_parking(10), **REPORT, reuse_solver=False, check=False)
    assert result.stats["linear_solver"]["factorizations"] > 0
    assert set(glob.glob(pattern)) <= before
