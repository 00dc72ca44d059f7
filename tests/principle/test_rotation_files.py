"""RotationTrajectory.save/load and OptimizationResult.save/load of a result on SO(3): an
exact round trip (every field bit for bit, the stats and the result's fields too), and
damaged or foreign files refused with a TrajectoryFileError naming what is wrong.

Oracles, none taken from the code under test: the damaged files are written here by plain
numpy (np.savez of the good file's arrays with one changed) and by hand (an empty file,
random bytes, a truncated copy)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc
from tests._helpers import same

ROTATION_FILE = "is not a valid dmoc trajectory file on SO(3) (one written by RotationTrajectory.save)"


@pytest.fixture(scope="module")
def rolled():
    """A 5-step roll of the steered Chaplygin sphere: a result whose trajectory has rotations,
    coordinates, their momenta, rolling multipliers and controls."""
    ball = dmoc.systems.chaplygin_sphere([1.0, 1.5, 2.5], 1.3, 0.7, torques=True)
    goal = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()
    problem = dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, 0.4), 5, R_start=np.eye(3),
                                              R_goal=goal, x_start=[0, 0], x_goal=[0.5, 0.2])
    return dmoc.optimize(problem)


@pytest.fixture
def good(rolled, tmp_path):
    """The file of the rolled trajectory and its arrays as numpy reads them."""
    rolled.trajectory.save(tmp_path / "good.npz")
    with np.load(tmp_path / "good.npz") as data:
        return tmp_path / "good.npz", dict(data)


def load_error(path, reader=dmoc.RotationTrajectory.load):
    with pytest.raises(dmoc.TrajectoryFileError) as info:
        reader(path)
    return str(info.value)


def test_a_simulated_trajectory_round_trips_bit_for_bit(tmp_path):
    R0 = Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
    traj = dmoc.simulate(dmoc.discretize(dmoc.systems.free_rigid_body((1.0, 2.0, 3.0)), 0.1),
                         q0=R0, v0=[1.0, 0.3, -0.7], steps=7).trajectory
    traj.save(tmp_path / "free.npz")
    back = dmoc.RotationTrajectory.load(tmp_path / "free.npz")
    assert same(back, traj) and back.h == traj.h and back.x.shape == (8, 0)


def test_a_result_on_the_group_round_trips_bit_for_bit(rolled, tmp_path):
    assert rolled.success and rolled.trajectory.lam.shape == (5, 2)
    rolled.save(tmp_path / "r.npz")
    back = dmoc.OptimizationResult.load(tmp_path / "r.npz")
    assert isinstance(back.trajectory, dmoc.RotationTrajectory)
    assert same(back.trajectory, rolled.trajectory)
    assert (back.cost, back.success, back.status, back.message, back.stats) == \
        (rolled.cost, rolled.success, rolled.status, rolled.message, rolled.stats)
    assert np.array_equal(back.x, rolled.x) and back.verdict == rolled.verdict and back.verdict.passed
    # the trajectory of the result file reads alone too
    assert same(dmoc.RotationTrajectory.load(tmp_path / "r.npz"), rolled.trajectory)


def test_the_other_kind_of_file_is_named(rolled, tmp_path):
    rolled.trajectory.save(tmp_path / "rot.npz")
    message = load_error(tmp_path / "rot.npz", dmoc.Trajectory.load)
    assert "it is the file of a trajectory on SO(3) (read it with RotationTrajectory.load)" in message
    message = load_error(tmp_path / "rot.npz", dmoc.OptimizationResult.load)
    assert "it is a trajectory file (read it with RotationTrajectory.load)" in message
    dmoc.Trajectory([0.0, 1.0], [[0.0], [1.0]], [[0.0]] * 2, [[]], [[1.0]], 1.0, "+").save(
        tmp_path / "vec.npz")
    message = load_error(tmp_path / "vec.npz")
    assert ROTATION_FILE in message
    assert "it is the file of a trajectory of a vector space (read it with Trajectory.load)" in message


def test_a_damaged_result_file_on_the_group_names_its_field(rolled, tmp_path):
    rolled.save(tmp_path / "r.npz")
    with np.load(tmp_path / "r.npz") as data:
        arrays = {k: v for k, v in data.items() if k != "f"}
    np.savez(tmp_path / "r.npz", **arrays)
    message = load_error(tmp_path / "r.npz", dmoc.OptimizationResult.load)
    assert "is not an optimization result file" in message and "it lacks the fields ['f']" in message


@pytest.mark.parametrize("content, what", [
    (b"", "it is empty"),
    (np.random.default_rng(1).bytes(500), "it is not an .npz (zip) archive"),
])
def test_damaged_files_are_refused(tmp_path, content, what):
    (tmp_path / "bad.npz").write_bytes(content)
    message = load_error(tmp_path / "bad.npz")
    assert ROTATION_FILE in message and what in message


def test_a_truncated_file_is_refused(good, tmp_path):
    path, _ = good
    data = path.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[:len(data) // 2])
    assert "it is truncated or corrupted" in load_error(tmp_path / "cut.npz")


@pytest.mark.parametrize("change, what", [
    (dict(R=None), "it lacks the fields ['R']"),
    (dict(f=None, Pi=None), "it lacks the fields ['Pi', 'f']"),
    (dict(omega=np.zeros(3)), "it holds fields a RotationTrajectory does not have: ['omega']"),
    (dict(R=np.zeros((6, 9))), "`R` must have shape (N+1, 3, 3), one rotation per knot; got (6, 9)"),
    (dict(R=np.full((6, 3, 3), "a")), "`R` must be an array of real numbers of shape (N+1, 3, 3)"),
    (dict(Pi=np.zeros((5, 3))), "`Pi` must have shape (6, 3)"),
    (dict(f=np.zeros((5, 2))), "`f` must have 3 + n_x columns"),
    (dict(x=np.zeros((6, 3))), "`x` must have shape (6, 2)"),
    (dict(lam=np.zeros((6, 2))), "`lam` must have shape (5, k), one row per step"),
    (dict(h=np.array([0.4, 0.4])), "`h` must be a single value"),
    (dict(h=np.array(-0.4)), "`h` must be"),
    (dict(t=np.arange(6.0)), "`t` must be the grid t_0 + k h with h = 0.4"),
    (dict(u=np.full((5, 3), np.inf)), "`u` must be finite"),
])
def test_a_damaged_field_is_refused_naming_it(good, tmp_path, change, what):
    _, arrays = good
    for name, value in change.items():
        if value is None:
            del arrays[name]
        else:
            arrays[name] = value
    np.savez(tmp_path / "crafted.npz", **arrays)
    message = load_error(tmp_path / "crafted.npz")
    assert ROTATION_FILE in message and what in message, message
