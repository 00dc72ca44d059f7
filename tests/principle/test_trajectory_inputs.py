"""Trajectory.control refuses times outside the horizon and non-numbers; Trajectory.save
and Trajectory.load refuse paths they cannot use, naming the user's path (never a
temporary file's).

Oracles, none taken from the code under test: a trajectory built by hand with controls
interpolated linearly between the node values 0, 2 (step 0) and 2, 4 (step 1), so the
control at any time of [0, 2] is known in closed form (u(t) = 2 t); the folders and files
are made here with pathlib."""

import numpy as np
import pytest

import dmoc


@pytest.fixture
def traj():
    """Two steps of h = 1 on [0, 2], n_u = 1, controls at the step ends: u(t) = 2 t."""
    return dmoc.Trajectory([0, 1, 2], [[0.0]] * 3, [[0.0]] * 3, [[], []],
                           [[0.0, 2.0], [2.0, 4.0]], 1.0, "+", control_nodes=(0.0, 1.0))


@pytest.mark.parametrize("t, bad", [(3.0, "3.0"), (-0.5, "-0.5"), ([0.5, 2.5], "2.5"),
                                    (np.nan, "nan")])
def test_control_outside_the_horizon_is_refused_naming_it(traj, t, bad):
    with pytest.raises(dmoc.InputError, match=r"`t` must lie in the horizon \[t_0, t_N\] = "
                                              rf"\[0.0, 2.0\]; t\[\d\] = {bad} is outside") as info:
        traj.control(t)
    assert isinstance(info.value, dmoc.DmocError)


def test_control_reads_round_off_at_the_ends_as_the_ends(traj):
    np.testing.assert_array_equal(traj.control([-1e-13, 2.0 + 1e-12])[:, 0], [0.0, 4.0])


def test_control_of_a_string_is_a_type_error(traj):
    with pytest.raises(dmoc.InputTypeError, match="`t` must be a time or a 1-D array of times; "
                                                  "got str") as info:
        traj.control("abc")
    assert isinstance(info.value, dmoc.DmocError)


def test_control_shapes(traj):
    """A scalar time gives shape (n_u,), K times K rows; the values are u(t) = 2 t."""
    assert traj.control(0.5).shape == (1,)
    np.testing.assert_allclose(traj.control(0.5), [1.0], rtol=0, atol=1e-15)
    times = np.array([0.0, 0.25, 1.0, 1.5, 2.0])
    np.testing.assert_allclose(traj.control(times), 2 * times[:, None], rtol=0, atol=1e-15)
    with pytest.raises(dmoc.InputError, match=r"`t` must be a time or a 1-D array of times; got "
                                              r"shape \(2, 1\)"):
        traj.control([[0.5], [1.5]])


def test_save_to_a_folder_names_the_folder(traj, tmp_path):
    with pytest.raises(dmoc.InputError, match="`path` must be a file name; got the folder "
                                              f"'{tmp_path}'") as info:
        traj.save(tmp_path)
    assert isinstance(info.value, dmoc.DmocError) and ".tmp" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_save_into_a_missing_folder_names_it(traj, tmp_path):
    target = tmp_path / "no" / "run.npz"
    with pytest.raises(dmoc.InputError, match="the folder of `path` must be an existing folder; "
                                              f"'{tmp_path / 'no'}' does not exist") as info:
        traj.save(target)
    assert isinstance(info.value, dmoc.DmocError) and ".tmp" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_save_into_a_file_as_folder_names_it(traj, tmp_path):
    (tmp_path / "plain").write_text("x")
    with pytest.raises(dmoc.InputError, match=f"'{tmp_path / 'plain'}', which is a file"):
        traj.save(tmp_path / "plain" / "run.npz")


def test_load_of_a_folder_names_it(tmp_path):
    with pytest.raises(dmoc.InputError, match=f"`path` must be a file; got the folder "
                                              f"'{tmp_path}'") as info:
        dmoc.Trajectory.load(tmp_path)
    assert isinstance(info.value, dmoc.DmocError)


def test_load_of_a_missing_file_is_a_file_not_found_dmoc_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="there is no file .*nothing.npz") as info:
        dmoc.Trajectory.load(tmp_path / "nothing.npz")
    assert isinstance(info.value, dmoc.DmocError)
    assert isinstance(info.value, dmoc.MissingFileError)


def test_saved_trajectory_still_loads(traj, tmp_path):
    traj.save(tmp_path / "run.npz")
    back = dmoc.Trajectory.load(tmp_path / "run.npz")
    np.testing.assert_array_equal(back.u, traj.u)


@pytest.mark.parametrize("t0, h, steps", [(0.0, 0.7, 10), (0.7, 0.1, 10), (0.0, 0.1, 100)])
def test_a_knot_belongs_to_the_step_that_starts_there_on_every_grid(t0, h, steps):
    """Grids t_k = t_0 + k h on which (t_k - t_0)/h rounds below k at some knots (k = 3 for
    h = 0.7; k = 1, 2, 7 from t_0 = 0.7; k = 43 of 100 steps of 0.1): at every knot t_k,
    k < N, `control` gives u_k = k, the held control of the step that starts there, and
    `sample` the velocity of that step's chord (q_{k+1} - q_k)/h = (2k + 1)/h for
    q_k = k^2; at t_N the last step's."""
    k = np.arange(steps + 1.0)
    q = (k ** 2)[:, None]
    traj = dmoc.Trajectory(t0 + h * k, q, q, np.zeros((steps, 0)), k[:-1, None], h, "+")
    np.testing.assert_array_equal(traj.control(traj.t)[:, 0], np.append(k[:-1], steps - 1))
    np.testing.assert_allclose(traj.sample(traj.t).v[:, 0], np.append(2 * k[:-1] + 1, 2 * steps - 1) / h,
                               rtol=1e-12, atol=0)
