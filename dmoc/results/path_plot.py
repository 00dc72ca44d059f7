"""Paths in the plane, part of the results stage: the path (q[:, x], q[:, y]) of a
Trajectory with heading marks, start, end, goal (a line where one coordinate is free), the
system's bodies at a few poses, and obstacles (`_obstacles`: discs, or a region
g(x, y) > 0), its labels with the system's units; the limits hold all of it, the obstacles
whole, to scale unless the motion is long and thin (`_canvas.plane_limits`).
"""

import numpy as np

from ._canvas import finish, label, not_to_scale_note, plane_limits, single_axes, units_of
from ._drawn_bodies import DrawnBodies, body_values, outlines
from ._obstacles import draw_obstacles, obstacle_extent, obstacle_values
from .._util import checks
from ..principle.trajectory import Trajectory


def plot_path(traj, *, x=0, y=1, heading=None, goal=None, labels=("x", "y"), units=None,
              obstacles=None, bodies=None, poses=5, marks=12, name="path", color="C0",
              title=None, ax=None):
    """The path (q[:, x], q[:, y]) of a Trajectory in the plane, with heading marks, the
    goal, the system's bodies at a few poses and obstacles.

    Parameters
    ----------
    traj : Trajectory
    x, y : int
        Columns of q plotted as the plane's coordinates.
    heading : int, optional
        Column of q holding the heading angle; arrows along it are drawn at `marks`
        evenly spaced knots (and at the goal).
    goal : array_like, shape (n,), optional
        Goal configuration, NaN entries free: a star, or a dotted line where one of the
        two plane coordinates is free.
    labels : pair of str
        Axis labels (the names of columns x and y).
    units : mapping, optional
        A system's `units` ({"t", "q", "u"}); those of columns x and y join the labels.
    obstacles : array_like, shape (K, 3), or callable, optional
        Discs (centre x, centre y, radius), or ``g(x, y)`` on arrays, the region g > 0
        kept out (the sign of `OptimalControlProblem`'s path constraints g <= 0). The
        limits hold every disc whole, and a region whole when it is bounded.
    bodies : sequence of Body, optional
        The bodies to draw (``system.bodies``), their outlines in the plane of columns x
        and y; drawn at `poses` knots evenly spaced along the path, from faint (the
        start) to solid (the end).
    poses : int
        Number of poses at which the bodies are drawn (at least the start and the end).
    marks : int
        Number of heading arrows along the path.
    name, color : str
        Legend entry and colour of this path (several paths can share `ax`).
    title : str, optional
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes instead of a new Figure.

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    The plot is to scale (equal aspect) unless the box of what it shows is more than
    `dmoc.results._canvas.ASPECT_LIMIT` (4) times as long as it is wide; then each axis
    has its own scale and the corner says "not to scale". The end marker lies over the
    goal's star.
    """
    q = checks.instance("traj", traj, Trajectory, "a Trajectory").q
    x, y = checks.column("x", x, q.shape[1]), checks.column("y", y, q.shape[1])
    heading = None if heading is None else checks.column("heading", heading, q.shape[1])
    goal = None if goal is None else checks.array("goal", goal, (q.shape[1],), allow_nan=True)
    labels = checks.strings("labels", labels, 2)
    unit = units_of(units, q.shape[1], traj.u.shape[1] // len(traj.control_nodes))["q"]
    marks = checks.positive_int("marks", marks)
    bodies, obstacles = body_values(bodies), obstacle_values(obstacles)
    poses = checks.positive_int("poses", poses)
    fig, ax = single_axes(ax, height=5.2)
    ax.plot(q[:, x], q[:, y], "-", lw=1.2, color=color, label=name, zorder=2)
    shown = ax.get_legend_handles_labels()[1]
    ax.plot(q[0, x], q[0, y], "o", color="C2", label="_nolegend_" if "start" in shown else "start",
            zorder=4)
    ax.plot(q[-1, x], q[-1, y], "s", color="C3", mfc="none", ms=9, mew=1.6, zorder=4,
            label="_nolegend_" if "end" in shown else "end")     # over the goal's star
    length = max(np.ptp(q[:, x]), np.ptp(q[:, y]), 1e-9) / 12      # of a heading arrow
    if heading is not None:
        k = _evenly_along(q[:, [x, y]], marks)
        _arrows(ax, q[k, x], q[k, y], q[k, heading], length, color, label="heading")
    if goal is not None:
        _goal(ax, goal, x, y, heading, 1.5 * length)
    for i, k in enumerate(_evenly_along(q[:, [x, y]], max(poses, 2)) if bodies else ()):
        DrawnBodies(ax, bodies, outlines(bodies, q[k])[0],
                    alpha=0.1 + 0.3 * i / max(poses - 1, 1), legend=k == len(q) - 1)
    _set_limits(ax, obstacles)
    draw_obstacles(ax, obstacles)
    ax.set_xlabel(label(labels[0], unit[x]))
    ax.set_ylabel(label(labels[1], unit[y]))
    return finish(fig, ax, title)


def _set_limits(ax, obstacles):
    """Limits holding what `ax` shows and every obstacle whole (`plane_limits`), to scale
    or with a note that they are not."""
    box = ax.dataLim.get_points()
    xlim, ylim, to_scale = plane_limits(np.r_[box, obstacle_extent(obstacles, box)])
    ax.update_datalim(np.transpose([xlim, ylim]))  # autoscaled: the aspect may widen one side
    ax.margins(0)
    ax.autoscale_view()
    if to_scale:
        ax.set_aspect("equal", adjustable="datalim")
        ax.apply_aspect()           # the final limits, over which a region is shaded
    else:
        ax.set_aspect("auto")
        if "not to scale" not in [t.get_text() for t in ax.texts]:
            not_to_scale_note(ax)


def _goal(ax, goal, x, y, heading, length):
    """The goal: a star (with its heading) where both coordinates are given, a dotted line
    across the plane where one of them is free."""
    gx, gy = np.isfinite(goal[[x, y]])
    if gx and gy:
        ax.plot(goal[x], goal[y], "*", ms=14, color="C1", label="goal", zorder=3)
        if heading is not None and np.isfinite(goal[heading]):
            _arrows(ax, goal[[x]], goal[[y]], goal[[heading]], length, "C1")
    elif gx or gy:
        line = ax.axvline if gx else ax.axhline
        line(goal[x] if gx else goal[y], color="C1", ls=":", lw=1.5,
             label=f"goal ({'y' if gx else 'x'} free)")


def _evenly_along(points, count):
    """Indices of `count` knots evenly spaced in arc length (in time if the path is a point)."""
    arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(points, axis=0).T))]
    if arc[-1] <= 0:
        arc = np.arange(len(points), dtype=float)
    return np.unique(np.searchsorted(arc, np.linspace(0, arc[-1], max(count, 2))).clip(0, len(points) - 1))


def _arrows(ax, x, y, angle, length, color, label=None):
    """Arrows of `length` (data units) from (x, y) along `angle`, kept inside the limits."""
    u, v = length * np.cos(angle), length * np.sin(angle)
    ax.quiver(x, y, u, v, color=color, angles="xy", scale_units="xy", scale=1, width=0.005,
              label=label)
    ax.update_datalim(np.column_stack([x + u, y + v]))
