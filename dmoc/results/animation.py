"""Animations of computed trajectories as GIF files, the results stage of the pipeline:
a knife edge or Chaplygin sleigh drawn as a blade, the vertical rolling disk as a coin with
its heading and rolling mark, and a generic marker for any planar system. Uses
matplotlib's animation with Pillow (imported lazily) on a bare Figure, never pyplot.
"""

import numpy as np

from .._util import checks
from .._util.files import atomic_path
from ..errors import InputError
from ..principle.trajectory import Trajectory

SHAPES = ("blade", "coin", "point")


def animate(traj, path, *, shape="point", x=0, y=1, heading=None, roll=None, goal=None,
            size=None, frames=60, fps=15, title=None):
    """Write an animation of the planar motion of `traj` to the GIF file `path`.

    Parameters
    ----------
    traj : Trajectory
    path : str or pathlib.Path
        The GIF file to write; its folder is created if missing.
    shape : {"blade", "coin", "point"}
        "blade": a segment along the heading (knife edge, sleigh); "coin": the rolling
        disk seen obliquely from above, a mark on its rim turning with the rolling angle;
        "point": a marker, with a heading arrow when `heading` is given.
    x, y : int
        Columns of q holding the position in the plane.
    heading : int, optional
        Column of q holding the heading angle (required for "blade" and "coin").
    roll : int, optional
        Column of q holding the rolling angle ("coin" only).
    goal : array_like, shape (n,), optional
        Goal configuration drawn as a star; NaN entries are free.
    size : float, optional
        Length of the drawn body; default a tenth of the path's extent (at least 0.1).
    frames : int
        Number of frames (knots are subsampled evenly; at most traj.steps + 1).
    fps : int
        Frames per second.
    title : str, optional

    Returns
    -------
    pathlib.Path
        The file written.
    """
    from matplotlib.animation import PillowWriter
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    q = checks.instance("traj", traj, Trajectory, "a Trajectory").q
    path = checks.file_path("path", path)
    shape = checks.choice("shape", shape, SHAPES)
    if shape != "point" and heading is None:
        raise InputError(f"`heading` must be a column of q for shape {shape!r}; got None.")
    x, y = checks.column("x", x, q.shape[1]), checks.column("y", y, q.shape[1])
    heading = None if heading is None else checks.column("heading", heading, q.shape[1])
    roll = None if roll is None else checks.column("roll", roll, q.shape[1])
    goal = None if goal is None else checks.array("goal", goal, (q.shape[1],), allow_nan=True)
    size = None if size is None else checks.positive_float("size", size)
    frames = min(checks.positive_int("frames", frames), traj.steps + 1)
    fps = checks.positive_float("fps", fps)
    path.parent.mkdir(parents=True, exist_ok=True)
    size = size or max(0.1, 0.1 * max(np.ptp(q[:, x]), np.ptp(q[:, y])))
    fig = Figure(figsize=(4.5, 4.5), dpi=80)
    fig.subplots_adjust(left=0.15, right=0.95, bottom=0.12, top=0.92)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    trail, = ax.plot([], [], "-", color="C0", lw=1)
    body = _Body(ax, shape, size)
    _frame_axes(ax, q[:, x], q[:, y], goal, (x, y), size, title)
    clock = ax.text(0.02, 0.96, "", transform=ax.transAxes, va="top")
    knots = np.unique(np.linspace(0, traj.steps, frames).round().astype(int))

    writer = PillowWriter(fps=fps)
    with atomic_path(path) as temporary, writer.saving(fig, temporary, dpi=fig.dpi):
        for k in knots:                                       # one draw per frame
            trail.set_data(q[: k + 1, x], q[: k + 1, y])
            angle = q[k, heading] if heading is not None else None
            body.move(q[k, x], q[k, y], angle, q[k, roll] if roll is not None else 0.0)
            clock.set_text(f"t = {traj.t[k]:.2f}")
            writer.grab_frame()
    return path


def _frame_axes(ax, xs, ys, goal, columns, size, title):
    """Fixed limits around the whole path (and goal), equal aspect, the goal drawn."""
    points_x, points_y = list(xs), list(ys)
    if goal is not None:
        g = np.asarray(goal, dtype=float)[list(columns)]
        if np.isfinite(g).all():
            ax.plot(*g, "*", ms=14, color="C1", label="goal")
            points_x.append(g[0])
            points_y.append(g[1])
    pad = 1.5 * size
    ax.set_autoscale_on(False)
    ax.set_xlim(min(points_x) - pad, max(points_x) + pad)
    ax.set_ylim(min(points_y) - pad, max(points_y) + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if title:
        ax.set_title(title)


class _Body:
    """The artists of one drawn body and how they follow a configuration."""

    def __init__(self, ax, shape, size):
        self.shape, self.size = shape, size
        if shape == "blade":
            self.outline, = ax.plot([], [], "-", color="k", lw=4, solid_capstyle="butt")
            self.mark, = ax.plot([], [], "o", color="C3", ms=5)      # the leading end
        elif shape == "coin":
            self.outline, = ax.plot([], [], "-", color="goldenrod", lw=2)
            self.mark, = ax.plot([], [], "o-", color="C3", ms=4, lw=1)   # spoke to rim mark
        else:
            self.outline, = ax.plot([], [], "o", color="C0", ms=8)
            self.mark, = ax.plot([], [], "-", color="C3", lw=2)      # heading arrow shaft

    def move(self, x, y, heading, roll):
        r = self.size / 2
        if heading is None:
            self.outline.set_data([x], [y])
            return
        e = np.array([np.cos(heading), np.sin(heading)])     # along the heading
        n = np.array([-e[1], e[0]])                           # normal to it
        c = np.array([x, y])
        if self.shape == "blade":
            ends = np.array([c - r * e, c + r * e])
            self.outline.set_data(ends[:, 0], ends[:, 1])
            self.mark.set_data([ends[1, 0]], [ends[1, 1]])
        elif self.shape == "coin":
            s = np.linspace(0, 2 * np.pi, 41)
            rim = c + r * np.outer(np.cos(s), e) + 0.3 * r * np.outer(np.sin(s), n)
            self.outline.set_data(rim[:, 0], rim[:, 1])
            spot = c - r * np.sin(roll) * e + 0.3 * r * np.cos(roll) * n
            self.mark.set_data([x, spot[0]], [y, spot[1]])
        else:
            self.outline.set_data([x], [y])
            tip = c + r * e
            self.mark.set_data([x, tip[0]], [y, tip[1]])
