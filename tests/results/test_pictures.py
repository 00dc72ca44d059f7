"""What the pictures of the whole system show, read back from their matplotlib objects and
the GIF's pixels: the declared bodies at the poses and frames, obstacles whole inside the
limits, the aspect rule on a long thin motion, control axes set by the data (bounds far
from it left out), the end marker over the goal's star, the controls' names in the labels.

Oracles written here: the obstacles' centres and radii, the number of poses times the
number of closed bodies, a 100 m lane change 3.5 m wide (ratio 28 > ASPECT_LIMIT = 4) and
a 1 m by 1 m parking (ratio 1), a +-1.5 ramp under +-15 bounds, the pixels of a body in a
colour no other artist uses.
"""

import pathlib

import casadi as ca
import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

import dmoc
from dmoc import plotting
from dmoc.problems import knife_edge_parking

MAGENTA = "#ff00ff"


@pytest.fixture(scope="module")
def parking():
    problem = knife_edge_parking(30)
    return problem, dmoc.optimize(problem).trajectory


def synthetic(q, n_u=2):
    """A Trajectory of the configurations `q` (K, n): only the drawing is under test."""
    q = np.asarray(q, dtype=float)
    N = len(q) - 1
    return dmoc.Trajectory(t=np.linspace(0, 1, N + 1), q=q, p=np.zeros_like(q),
                           lam=np.zeros((N, 0)), u=np.linspace(-1.5, 1.5, N)[:, None] * np.ones(n_u),
                           h=1.0 / N, variant="+")


def lane_change(length=100.0, width=3.5, steps=50):
    s = np.linspace(0, 1, steps + 1)
    y = width * (3 * s ** 2 - 2 * s ** 3)
    theta = np.arctan2(np.gradient(y), np.gradient(length * s))
    return synthetic(np.column_stack([length * s, y, theta, np.zeros_like(s)]))


def drawn(fig):
    fig.canvas.draw()
    return fig.axes[0]


def test_bodies_are_drawn_at_each_pose(parking):
    problem, traj = parking
    trailer = dmoc.Body("trailer", lambda q: dmoc.mechanics.bodies.rectangle(
        q[:2] - 0.3 * np.array([np.cos(q[2]), np.sin(q[2])]), q[2], 0.3, 0.1))
    bodies = (*problem.disc.system.bodies, trailer, dmoc.Body("hitch", lambda q: q[None, :2]))
    ax = drawn(plotting.plot_path(traj, bodies=bodies, poses=4))
    names = [a.get_gid() for a in [*ax.patches, *ax.lines] if (a.get_gid() or "").startswith("body")]
    assert sorted(names) == sorted(["body blade", "body trailer", "body hitch"] * 4)
    polygons = [p for p in ax.patches if type(p).__name__ == "Polygon"]
    assert len(polygons) == 2 * 4                    # two closed bodies at four poses
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert [legend.count(name) for name in ("blade", "trailer", "hitch")] == [1, 1, 1]
    assert not plotting.plot_path(traj).axes[0].patches          # no bodies, none drawn


def test_save_trajectory_plots_draws_the_system_bodies_and_names_its_controls(parking):
    problem, traj = parking
    figures = plotting._figures(traj, "park", problem.disc, problem, ("x", "y", "theta"),
                                problem.disc.system.control_names, problem.disc.system.units,
                                2, None, None)
    assert any(p.get_gid() == "body blade" for p in figures["path"].axes[0].patches)
    assert [ax.get_ylabel() for ax in figures["controls"].axes] == ["force [N]", "torque [N m]"]


def test_the_system_control_names_are_the_default_labels(tmp_path, parking, monkeypatch):
    problem, traj = parking
    system = dmoc.MechanicalSystem(lambda q, v: (v[0] ** 2 + v[1] ** 2 + v[2] ** 2) / 2, 3,
                                   force=lambda q, v, u: ca.vertcat(u, 0), n_u=2,
                                   names=("x", "y", "theta"), control_names=("thrust", "yaw"))
    disc = dmoc.discretize(system, problem.disc.h)
    labels = []
    drawn_controls = plotting.plot_controls

    def recorded(*args, **kwargs):
        fig = drawn_controls(*args, **kwargs)
        labels.extend(ax.get_ylabel() for ax in fig.axes)
        return fig

    monkeypatch.setattr(plotting, "plot_controls", recorded)
    traj = dmoc.Trajectory(t=traj.t, q=traj.q, p=traj.p, lam=np.zeros((traj.steps, 0)),
                           u=traj.u, h=traj.h, variant="+")
    plotting.save_trajectory_plots(traj, tmp_path, "own", disc=disc)
    assert labels == ["thrust", "yaw"]


@pytest.mark.parametrize("obstacles", [
    [[0.4, 0.5, 0.15], [3.0, -2.0, 0.5]],                      # one far from the path
    lambda x, y: 0.25 - (x - 1.5) ** 2 - (y - 2.0) ** 2])      # a disc as a kept-out region
def test_every_obstacle_lies_whole_inside_the_limits(parking, obstacles):
    _, traj = parking
    ax = drawn(plotting.plot_path(traj, obstacles=obstacles))
    discs = [(1.5, 2.0, 0.5)] if callable(obstacles) else obstacles
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for x, y, r in discs:
        assert x0 <= x - r and x + r <= x1 and y0 <= y - r and y + r <= y1, (ax.get_xlim(), ax.get_ylim())


def test_a_long_thin_motion_keeps_its_width_and_a_square_one_is_to_scale(parking):
    ax = drawn(plotting.plot_path(lane_change(), heading=2))
    assert ax.get_aspect() == "auto"
    assert "not to scale" in [t.get_text() for t in ax.texts]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert y1 - y0 < 2 * 3.5 and x1 - x0 < 1.3 * 100     # the 3.5 m fill the height
    ax = drawn(plotting.plot_path(parking[1], heading=2))
    assert ax.get_aspect() == 1.0 and not ax.texts


def test_a_straight_run_is_not_stretched_to_noise():
    s = np.linspace(0, 10, 21)
    ax = drawn(plotting.plot_path(synthetic(np.column_stack([s, 1e-12 * np.sin(s), 0 * s]))))
    (y0, y1) = ax.get_ylim()
    assert y1 - y0 > 10 / 60                              # at least a 1/50 of the length


def test_the_end_marker_lies_over_the_goal(parking):
    problem, traj = parking
    ax = plotting.plot_path(traj, goal=problem.q_goal).axes[0]
    (end,) = [line for line in ax.lines if line.get_label() == "end"]
    (goal,) = [line for line in ax.lines if line.get_label() == "goal"]
    assert end.get_zorder() > goal.get_zorder()
    assert np.allclose(end.get_xydata(), goal.get_xydata(), atol=1e-3)   # both at (0, 1)


def bound_lines(ax):
    return sorted(line.get_ydata()[0] for line in ax.lines if line.get_linestyle() == "--")


def test_control_axes_are_set_by_the_data_not_by_far_bounds():
    traj = lane_change(steps=20)                # controls: a ramp from -1.5 to 1.5
    fig = plotting.plot_controls(traj, bounds=([-15.0, -2.0], [15.0, 2.0]))
    far, near = fig.axes
    assert bound_lines(far) == [] and bound_lines(near) == [-2.0, 2.0]
    assert -1.8 < far.get_ylim()[0] < -1.5 and 1.5 < far.get_ylim()[1] < 1.8
    assert near.get_ylim()[0] < -2.0 and near.get_ylim()[1] > 2.0
    assert any("15" in t.get_text() and "off the axes" in t.get_text() for t in far.texts)


def frames_of(path):
    with Image.open(path) as gif:
        for i in range(gif.n_frames):
            gif.seek(i)
            yield np.asarray(gif.convert("RGB")).astype(int)


def test_the_gif_draws_the_bodies_every_frame_and_the_obstacle_whole(parking, tmp_path):
    problem, traj = parking
    blade = dmoc.Body("blade", problem.disc.system.bodies[0].outline, color=MAGENTA)
    path = dmoc.animation.animate(traj, tmp_path / "park.gif", bodies=[blade], frames=6,
                                  goal=problem.q_goal, obstacles=[[0.9, 0.5, 0.3]])
    gray = []
    for image in frames_of(path):
        magenta = (image[..., 0] > 200) & (image[..., 1] < 80) & (image[..., 2] > 200)
        assert magenta.sum() > 10                          # the blade, in every frame
        fill = (np.abs(image - 191) <= 2).all(axis=-1)     # the disc's fill, 0.75 grey
        parts, count = ndimage.label(fill)                 # the largest grey part: the disc
        rows, columns = np.nonzero(parts == 1 + np.argmax(np.bincount(parts.ravel())[1:]))
        gray.append((np.ptp(rows), np.ptp(columns)))
    height, width = gray[-1]
    assert abs(height - width) <= 3 and height > 20        # round, not cut by the axes


def test_a_gif_of_a_long_thin_motion_is_wide_and_not_to_scale(tmp_path):
    car = dmoc.systems.car()
    path = dmoc.animation.animate(lane_change(), tmp_path / "lane.gif", bodies=car.bodies,
                                  frames=3)
    with Image.open(path) as gif:
        assert 1.6 < gif.size[0] / gif.size[1] < 2.6


def test_bodies_or_a_shape_not_both(parking, tmp_path):
    problem, traj = parking
    with pytest.raises(dmoc.InputError, match=r"give `bodies` or `shape`, not both"):
        dmoc.animation.animate(traj, tmp_path / "a.gif", bodies=problem.disc.system.bodies,
                               shape="blade", heading=2)
    with pytest.raises(dmoc.InputTypeError, match=r"`bodies` must be a list or tuple of dmoc.Body"):
        plotting.plot_path(traj, bodies=problem.disc.system.bodies[0])
    with pytest.raises(dmoc.InputError, match=r"`heading` must be a column of q for shape 'coin'"):
        dmoc.animation.animate(traj, tmp_path / "a.gif", shape="coin")


def test_the_command_line_gif_draws_the_car_and_the_parked_car(tmp_path):
    """`dmoc optimize lane_change_problem.py:lane_change --animate`: every frame shows the
    car's body (its edge in C1, orange) and the grey disc its path constraints keep out."""
    from dmoc.cli import main

    example = pathlib.Path(__file__).parents[2] / "examples" / "lane_change_problem.py"
    assert main(["optimize", f"{example}:lane_change", "--param", "steps=30", "--out",
                 str(tmp_path), "--animate", "--no-plots"]) == 0
    for image in frames_of(tmp_path / "lane_change.gif"):
        orange = (np.abs(image - [255, 127, 14]) <= 30).all(axis=-1)
        grey = (np.abs(image - 191) <= 2).all(axis=-1)
        assert orange.sum() > 20 and grey.sum() > 200
