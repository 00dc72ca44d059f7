"""dmoc.plotting and dmoc.animation: reachable after `import dmoc`, Figures returned and
never shown, folders given as str created, headings, goal, names and log scales drawn."""

import numpy as np
import pytest
from PIL import Image

import dmoc
from dmoc.problems import knife_edge_parking


@pytest.fixture(scope="module")
def parked():
    problem = knife_edge_parking(20)
    return problem, dmoc.optimize(problem).trajectory


def test_reachable_after_import_dmoc():
    assert callable(dmoc.plotting.plot_path) and callable(dmoc.animation.animate)


def test_save_trajectory_plots_creates_a_str_folder(parked, tmp_path):
    problem, traj = parked
    folder = str(tmp_path / "new" / "plots")
    written = dmoc.plotting.save_trajectory_plots(traj, folder, "park", disc=problem.disc,
                                                  heading=2, goal=problem.q_goal)
    assert [p.name for p in written] == ["park_path.png", "park_states.png", "park_controls.png",
                                         "park_constraint.png", "park_energy.png"]
    assert all(p.stat().st_size > 1000 for p in written)


def test_path_has_heading_marks_and_goal(parked):
    problem, traj = parked
    ax = dmoc.plotting.plot_path(traj, heading=2, goal=problem.q_goal, marks=8).axes[0]
    arrows = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    assert len(arrows) == 2 and arrows[0].N == 8     # along the path, and at the goal
    assert "goal" in ax.get_legend_handles_labels()[1]


def test_states_and_controls_use_names(parked):
    _, traj = parked
    fig = dmoc.plotting.plot_states(traj, names=("x", "y", "theta"))
    assert [a.get_ylabel() for a in fig.axes] == ["x", "y", "theta"]
    fig = dmoc.plotting.plot_controls(traj, names=["force", "torque"])
    assert [a.get_ylabel() for a in fig.axes] == ["force", "torque"]


def test_errors_on_log_scales_without_offset_notation(parked):
    problem, traj = parked
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    free = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=50).trajectory
    for fig in (dmoc.plotting.plot_energy_error(disc, free),
                dmoc.plotting.plot_constraint_violation(problem.disc, traj)):
        ax = fig.axes[0]
        assert ax.get_yscale() == "log"
        data = ax.lines[0].get_ydata()
        assert np.all(np.isnan(data) | (data > 0))


def test_convergence_plots():
    h = np.array([0.1, 0.05, 0.025])
    ax = dmoc.plotting.plot_convergence(h, 3 * h**2, order=2).axes[0]
    assert ax.get_xscale() == ax.get_yscale() == "log"
    np.testing.assert_allclose(ax.lines[1].get_ydata(), 3 * h**2)
    ax = dmoc.plotting.plot_cost_convergence([25, 50, 100], [8.88, 8.76, 8.73]).axes[0]
    assert ax.get_xlabel().startswith("N")


@pytest.mark.parametrize("shape, extra", [("blade", {"heading": 2}),
                                          ("point", {}), ("coin", {"heading": 2, "roll": 1})])
def test_animation_writes_a_small_gif(parked, tmp_path, shape, extra):
    problem, traj = parked
    path = dmoc.animation.animate(traj, str(tmp_path / "sub" / "a.gif"), shape=shape,
                                  goal=problem.q_goal, frames=8, **extra)
    with Image.open(path) as gif:
        assert gif.n_frames == 8


def test_animation_needs_a_heading_for_bodies(parked, tmp_path):
    with pytest.raises(ValueError, match="`heading`"):
        dmoc.animation.animate(parked[1], tmp_path / "a.gif", shape="blade")


def test_a_failing_figure_write_keeps_the_previous_file(tmp_path, monkeypatch):
    """Figures are written atomically too: a savefig that fails half-way leaves the old PNG."""
    from matplotlib.figure import Figure

    import dmoc
    traj = dmoc.simulate(dmoc.discretize(dmoc.systems.knife_edge(), 0.1), q0=[0, 0, 0],
                         v0=[1, 0, 1], steps=5).trajectory
    first = dmoc.plotting.save_trajectory_plots(traj, tmp_path, "run")
    before = {p: p.read_bytes() for p in first}

    def broken(self, file, **kwargs):
        file.write(b"partial")
        raise OSError("disk full")
    monkeypatch.setattr(Figure, "savefig", broken)
    try:
        dmoc.plotting.save_trajectory_plots(traj, tmp_path, "run")
    except OSError:
        pass
    assert {p: p.read_bytes() for p in first} == before
    assert not list(tmp_path.glob(".*.tmp"))
