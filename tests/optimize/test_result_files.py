"""OptimizationResult.load refuses files that are not results, saying what the file is and
what was expected; OptimizationResult.save refuses paths it cannot use; an IPOPT option
that IPOPT refuses (a linear solver it does not have) is reported as that, not as a
violated constraint.

Oracles, none taken from the code under test: the files are written here by
Trajectory.save, by plain numpy and by hand (random bytes, an empty file); a result is
built by hand; the IPOPT bundled with CasADi has no HSL solver (ma57), only MUMPS."""

import numpy as np
import pytest

import dmoc
from dmoc.systems import knife_edge


@pytest.fixture
def traj():
    return dmoc.Trajectory([0.0, 0.5, 1.0], [[0.0], [1.0], [2.0]], [[0.0]] * 3, [[], []],
                           [[1.0], [2.0]], 0.5, "+")


def load_error(path):
    with pytest.raises(dmoc.TrajectoryFileError) as info:
        dmoc.OptimizationResult.load(path)
    assert isinstance(info.value, dmoc.DmocError)
    return str(info.value)


def test_a_trajectory_file_is_not_a_result(traj, tmp_path):
    traj.save(tmp_path / "t.npz")
    message = load_error(tmp_path / "t.npz")
    assert "is not an optimization result file (one written by OptimizationResult.save)" in message
    assert "lacks the fields ['cost'," in message
    assert "it is a trajectory file (read it with Trajectory.load)" in message


@pytest.mark.parametrize("content, what", [
    (b"", "it is empty"),
    (np.random.default_rng(1).bytes(500), "it is not an .npz (zip) archive"),
])
def test_damaged_files_are_not_results(tmp_path, content, what):
    (tmp_path / "r.npz").write_bytes(content)
    message = load_error(tmp_path / "r.npz")
    assert "is not an optimization result file" in message and what in message


def test_an_npy_file_is_not_a_result(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros(3))
    message = load_error(tmp_path / "a.npy")
    assert "is not an optimization result file" in message
    assert "it is an .npy file (one array), not an .npz archive" in message


def test_save_and_load_name_the_users_path(traj, tmp_path):
    result = dmoc.OptimizationResult(traj, 1.5, True, "Solve_Succeeded", "done")
    with pytest.raises(dmoc.InputError, match=f"`path` must be a file name; got the folder '{tmp_path}'"):
        result.save(tmp_path)
    with pytest.raises(dmoc.InputError, match="the folder of `path` must be an existing folder"):
        result.save(tmp_path / "no" / "r.npz")
    with pytest.raises(FileNotFoundError, match="there is no file") as info:
        dmoc.OptimizationResult.load(tmp_path / "none.npz")
    assert isinstance(info.value, dmoc.DmocError)
    result.save(tmp_path / "r.npz")
    back = dmoc.OptimizationResult.load(tmp_path / "r.npz")
    assert (back.cost, back.status, back.message) == (1.5, "Solve_Succeeded", "done")


def test_a_linear_solver_ipopt_lacks_is_named(capfd):
    """Before any solver is built: the option, that this build lacks it, and what it has."""
    problem = dmoc.OptimalControlProblem(dmoc.discretize(knife_edge(), 0.1), 5,
                                         q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.InputError) as info:
        dmoc.optimize(problem, options={"linear_solver": "ma57"})
    assert capfd.readouterr().out == ""
    message = str(info.value)
    assert message.startswith("`options['linear_solver']` = 'ma57' is not available in this "
                              "IPOPT build, which has 'mumps'")
    with pytest.raises(dmoc.InputError, match=r"`options\['linear_solver'\]` must be one of "
                       "IPOPT's linear solvers 'mumps', .*; got 'ma99'"):
        dmoc.optimize(problem, options={"linear_solver": "ma99"})

def test_a_probe_that_found_no_solver_refuses_none_for_availability(monkeypatch):
    """The probe of the build's linear solvers crashed or hung before its first find: a
    known name is passed on to IPOPT (which reports an unavailable one itself) instead of an
    IndexError from the message; an unknown name is still refused."""
    from dmoc.optimal_control.solver import linear_solver_choice as choice
    monkeypatch.setattr(choice, "available", lambda: ())
    choice.check_linear_solver({"linear_solver": "mumps"})
    with pytest.raises(dmoc.InputError, match="must be one of IPOPT's linear solvers"):
        choice.check_linear_solver({"linear_solver": "ma99"})
