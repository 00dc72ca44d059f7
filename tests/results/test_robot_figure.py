"""`dmoc.plotting.plot_robot`: the drawn stick figure is the robot's own kinematic tree at
the chosen knots. Oracle: the link origins from `RobotSystem.link_position` one link and
knot at a time (not the figure's batched evaluation), the tree's parent indices, and the
tool's path at every knot."""

import numpy as np
import pytest

import dmoc
from dmoc.errors import InputError, InputTypeError
from dmoc.mechanics.robots import example_urdf


@pytest.fixture(scope="module")
def arm_motion():
    arm = dmoc.RobotSystem(example_urdf("arm6"))
    q0 = np.array([0.0, -0.5, 1.0, -0.5, 0.0, 0.0])
    run = dmoc.simulate(dmoc.discretize(arm, 0.01), q0=q0, v0=np.zeros(6), steps=8)
    return arm, run.trajectory


def test_the_segments_join_each_link_to_its_parent_at_the_chosen_knots(arm_motion):
    arm, traj = arm_motion
    figure = dmoc.plotting.plot_robot(arm, traj, poses=3)
    ax = figure.axes[0]
    segments = [line for line in ax.lines if line.get_label().startswith("_")]
    tree = [(link.parent, i) for i, link in enumerate(arm.links) if link.parent is not None]
    assert len(segments) == 3 * len(tree)
    for pose, k in enumerate((0, 4, 8)):
        for (parent, child), line in zip(tree, segments[pose * len(tree):]):
            x, y, z = line.get_data_3d()
            for end, link in zip(range(2), (parent, child)):
                origin = arm.link_position(arm.links[link].name)(traj.q[k]).full().ravel()
                np.testing.assert_allclose([x[end], y[end], z[end]], origin, atol=1e-12)
    (path,) = [line for line in ax.lines if line.get_label() == f"{arm.links[-1].name}'s path"]
    tool = arm.link_position(arm.links[-1].name)
    np.testing.assert_allclose(np.array(path.get_data_3d()).T,
                               [tool(q).full().ravel() for q in traj.q], atol=1e-12)


def test_bad_arguments_are_refused_by_name(arm_motion):
    arm, traj = arm_motion
    with pytest.raises(InputError, match="`robot` must be a dmoc.RobotSystem"):
        dmoc.plotting.plot_robot(dmoc.systems.knife_edge(), traj)
    with pytest.raises(InputTypeError, match="`traj`"):
        dmoc.plotting.plot_robot(arm, traj.q)
    with pytest.raises(InputError, match="`trace`"):
        dmoc.plotting.plot_robot(arm, traj, trace="nowhere")
    with pytest.raises(InputError, match="`poses`"):
        dmoc.plotting.plot_robot(arm, traj, poses=0)
