"""`dmoc.plotting.plot_body` and `plot_body_rates`: what is drawn is the trajectory's.
Oracles: the stored R_k and x_k of the knots (each axis from x_k to x_k + length R_k e_i),
the held controls, and the body angular velocity of each step from its Cayley
coordinates f_k, written here: Omega at the step's start is f_k / h (the derivative of
R_k cay(c f_k) at c = 0)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc
from dmoc.errors import InputError, InputTypeError


@pytest.fixture(scope="module")
def roll():
    ball = dmoc.systems.chaplygin_sphere((1.0, 1.5, 2.5), 1.3, 0.7, torques=True)
    goal = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()
    problem = dmoc.GroupOptimalControlProblem(dmoc.discretize(ball, 0.25), 8, R_start=np.eye(3),
                                              R_goal=goal, x_start=[0, 0], x_goal=[1.0, 0.5])
    return dmoc.optimize(problem).trajectory


def test_the_axes_are_the_columns_of_r_at_the_chosen_knots_and_the_path_is_x(roll):
    figure = dmoc.plotting.plot_body(roll, frames=3, length=0.2)
    ax = figure.axes[0]
    axes = {line.get_gid(): np.array(line.get_data_3d()).T for line in ax.lines if line.get_gid()}
    assert sorted(axes) == sorted(f"axis {i} at knot {k}" for i in range(3) for k in (0, 4, 8))
    for k in (0, 4, 8):
        x = np.append(roll.x[k], 0.0)
        for i in range(3):
            np.testing.assert_allclose(axes[f"axis {i} at knot {k}"], [x, x + 0.2 * roll.R[k][:, i]],
                                       rtol=0, atol=1e-15)
    (path,) = [line for line in ax.lines if line.get_label() == "path of x"]
    np.testing.assert_array_equal(np.array(path.get_data_3d()).T,
                                  np.column_stack([roll.x, np.zeros(9)]))


def test_the_rates_are_the_steps_angular_velocity_and_the_held_controls(roll):
    figure = dmoc.plotting.plot_body_rates(roll, control_names=["t1", "t2", "t3"])
    panels = figure.axes
    assert len(panels) == 3 + 2 + 3
    h = roll.h
    for i in range(3):
        t, omega = panels[i].lines[0].get_data()
        np.testing.assert_allclose(omega[:-1:8], roll.f[:, i] / h, rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(t[::8], roll.t)
    for i in range(2):
        t, rate = panels[3 + i].lines[0].get_data()
        np.testing.assert_allclose(rate[:-1:8], np.diff(roll.x[:, i]) / h, rtol=1e-13, atol=1e-13)
    for j in range(3):
        (stairs,) = panels[5 + j].patches
        np.testing.assert_array_equal(stairs.get_data().values, roll.u[:, j])
        assert panels[5 + j].get_ylabel() == f"t{j + 1}"


def test_bad_arguments_are_refused_by_name(roll):
    with pytest.raises(InputTypeError, match="`traj` must be a RotationTrajectory"):
        dmoc.plotting.plot_body(dmoc.simulate(dmoc.discretize(dmoc.systems.knife_edge(), 0.1),
                                              q0=[0, 0, 0], v0=[0, 0, 0], steps=2).trajectory)
    with pytest.raises(InputError, match="`frames`"):
        dmoc.plotting.plot_body(roll, frames=0)
    with pytest.raises(InputError, match="`length`"):
        dmoc.plotting.plot_body(roll, length=-1.0)
    with pytest.raises(InputError, match="`control_names` must be 3 strings"):
        dmoc.plotting.plot_body_rates(roll, control_names=["only one"])


def test_the_gif_has_a_frame_per_chosen_knot_and_the_body_moves(roll, tmp_path):
    """`dmoc.animation.animate_body`: one frame per knot of `frame_knots` (3 of 9 knots),
    the frames differ as the body turns and rolls, and the axes it draws are those of
    `plot_body` (the same `body_axes`, checked above against R_k and x_k)."""
    from PIL import Image

    path = dmoc.animation.animate_body(roll, tmp_path / "roll.gif", frames=3, length=0.2)
    with Image.open(path) as gif:
        assert gif.n_frames == 3
        shown = []
        for i in range(3):
            gif.seek(i)
            shown.append(np.asarray(gif.convert("RGB"), dtype=int))
    assert all(np.abs(a - b).sum() > 0 for a, b in zip(shown[:-1], shown[1:]))
    with pytest.raises(InputTypeError, match="`traj` must be a RotationTrajectory"):
        dmoc.animation.animate_body(roll.q, tmp_path / "x.gif")
    with pytest.raises(InputError, match="`frames`"):
        dmoc.animation.animate_body(roll, tmp_path / "x.gif", frames=0)
