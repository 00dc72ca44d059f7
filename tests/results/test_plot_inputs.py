"""Plots of degenerate trajectories say what they show, and save_trajectory_plots refuses
a `name` with a path separator and an `out` that is a file, naming them, before writing.

Oracles, none taken from the code under test: a one-step trajectory has a single energy
value (at its step's midpoint), so there is no change of it to draw; the folders and
files are made here with pathlib."""

import pytest

import dmoc
from dmoc import plotting
from dmoc.systems import knife_edge


@pytest.fixture(scope="module")
def knife():
    disc = dmoc.discretize(knife_edge(), 0.1)
    return disc, dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=3).trajectory


def texts(fig):
    return [text.get_text() for ax in fig.axes for text in ax.texts]


def test_energy_plot_of_one_step_says_there_is_no_change(knife):
    disc, _ = knife
    one = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=1).trajectory
    notes = texts(plotting.plot_energy_error(disc, one))
    assert len(notes) == 1 and notes[0].startswith("one step:") and "no change" in notes[0]
    assert "identically zero" not in notes[0]


def test_energy_plot_of_two_steps_draws_the_change(knife):
    disc, traj = knife
    fig = plotting.plot_energy_error(disc, traj)
    assert "one step" not in " ".join(texts(fig))
    assert len(fig.axes[0].lines[0].get_ydata()) == traj.steps - 1


@pytest.mark.parametrize("name", ["sub/run", "a\\b"])
def test_a_name_with_a_path_separator_is_refused(knife, tmp_path, name):
    _, traj = knife
    with pytest.raises(dmoc.InputError, match="`name` must be a file-name prefix without a path "
                                              f"separator; got {name!r}".replace("\\", "\\\\")) as info:
        plotting.save_trajectory_plots(traj, tmp_path, name)
    assert isinstance(info.value, dmoc.DmocError)
    assert list(tmp_path.iterdir()) == []


def test_an_out_that_is_a_file_is_refused(knife, tmp_path):
    _, traj = knife
    (tmp_path / "plain").write_text("x")
    with pytest.raises(dmoc.InputError, match=f"`out` must be a folder .*; got "
                                              f"'{tmp_path / 'plain'}', which is a file") as info:
        plotting.save_trajectory_plots(traj, tmp_path / "plain", "run")
    assert isinstance(info.value, dmoc.DmocError)
    with pytest.raises(dmoc.InputError, match=f"its parent '{tmp_path / 'plain'}' is a file"):
        plotting.save_trajectory_plots(traj, tmp_path / "plain" / "deeper", "run")
    assert (tmp_path / "plain").read_text() == "x"


def test_missing_folders_of_out_are_created(knife, tmp_path):
    _, traj = knife
    written = plotting.save_trajectory_plots(traj, tmp_path / "a" / "b", "run")
    assert written and all(p.parent == tmp_path / "a" / "b" and p.is_file() for p in written)
