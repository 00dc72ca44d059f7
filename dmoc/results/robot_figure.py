"""A robot's motion drawn in three dimensions (results stage): its kinematic tree as a stick
figure, a segment from each link's frame origin to each child's, at a few times of a
trajectory, fading from the first to the last, and the path of one link (the tool). The
positions are the robot's own forward kinematics (`RobotSystem.link_position`), evaluated
once for every link and time.
"""

import os

import casadi as ca
import numpy as np

from .._util import checks
from ..errors import InputError
from ..principle.trajectory import Trajectory
from ._canvas import DPI


def link_positions(robot, q):
    """The world positions of every link's frame origin, shape (K, len(robot.links), 3), at
    the configurations `q` (K, n)."""
    x = ca.SX.sym("q", robot.n)
    frames = ca.Function("frames", [x], [ca.horzcat(*[robot.link_position(link.name)(x)
                                                      for link in robot.links]).T])
    return np.stack([np.asarray(frames(row)) for row in np.atleast_2d(q)])


def plot_robot(robot, traj, *, poses=5, trace=None, title=None):
    """The stick figure of `robot` at `poses` times of `traj`, evenly spread from its start
    to its end (the earlier ones lighter), the path of the link `trace`, and the floor's
    plane z = 0 for a wheeled base.

    Parameters
    ----------
    robot : dmoc.RobotSystem
    traj : Trajectory
        A motion of `robot` (its q of shape (N + 1, robot.n)).
    poses : int, optional
        How many poses to draw (at least 1; the knots nearest to even times).
    trace : str, optional
        A link whose origin's path is drawn at every knot (default: the last link of the
        tree, the tool of a serial arm).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        One 3-D Axes, equal scales on x, y and z; never shown.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    links = getattr(robot, "links", None)
    if not links or not callable(getattr(robot, "link_position", None)):
        raise InputError(f"`robot` must be a dmoc.RobotSystem; got {type(robot).__name__}.")
    checks.instance("traj", traj, Trajectory, "a Trajectory of the robot")
    if traj.q.shape[1] != robot.n:
        raise InputError(f"`traj` must be a motion of the robot's n = {robot.n} coordinates; "
                         f"its q has {traj.q.shape[1]} columns.")
    poses = checks.positive_int("poses", poses)
    names = [link.name for link in links]
    trace = names[-1] if trace is None else trace
    checks.choice("trace", trace, tuple(names))
    every = link_positions(robot, traj.q)
    shown = np.unique(np.round(np.linspace(0, traj.steps, poses)).astype(int))
    fig = Figure(figsize=(6.4, 5.2), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    for order, k in enumerate(shown):
        shade = 0.25 + 0.75 * (order + 1) / len(shown)
        for i, link in enumerate(links):
            if link.parent is not None:
                segment = every[k, [link.parent, i]]
                ax.plot(*segment.T, color=(0.1, 0.3, 0.7, shade), lw=2.5, solid_capstyle="round")
        ax.scatter(*every[k].T, color=(0.1, 0.1, 0.1, shade), s=8, depthshade=False)
    path = every[:, names.index(trace)]
    ax.plot(*path.T, color="tab:red", lw=1.2, label=f"{trace}'s path")
    if getattr(robot, "wheels", ()):
        corners = every[:, :, :2].reshape(-1, 2)
        (x0, y0), (x1, y1) = corners.min(axis=0) - 0.2, corners.max(axis=0) + 0.2
        ax.plot_surface(*np.meshgrid([x0, x1], [y0, y1]), np.zeros((2, 2)), color="0.85", alpha=0.4)
    low, high = every.reshape(-1, 3).min(axis=0), every.reshape(-1, 3).max(axis=0)
    middle, half = (low + high) / 2, max((high - low).max() / 2, 0.05)
    ax.set(xlim=(middle[0] - half, middle[0] + half), ylim=(middle[1] - half, middle[1] + half),
           zlim=(middle[2] - half, middle[2] + half), xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
    ax.set_box_aspect((1, 1, 1))
    ax.legend(fontsize="small", loc="upper left")
    model = os.path.splitext(os.path.basename(str(robot.path)))[0]
    ax.set_title(title or f"{model}: {len(shown)} poses from t = {traj.t[0]:.3g} to {traj.t[-1]:.3g} s")
    return fig
