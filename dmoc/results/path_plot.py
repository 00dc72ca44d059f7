"""Paths in the plane, part of the results stage: the path (q[:, x], q[:, y]) of a
Trajectory with heading marks, start, end, goal (a line where one coordinate is free) and
obstacles (discs by centre and radius, or the region g(x, y) > 0 of a function on the
plane, the sign of an `OptimalControlProblem`'s path constraints g <= 0, shaded on a grid),
its labels with the system's units.
"""

import numpy as np

from ._canvas import finish, label, single_axes, units_of
from .._util import checks
from ..errors import InputError
from ..principle.trajectory import Trajectory

_GRID = 160     # points per side of the grid a kept-out region is shaded on


def plot_path(traj, *, x=0, y=1, heading=None, goal=None, labels=("x", "y"), units=None,
              obstacles=None, marks=12, name="path", color="C0", title=None, ax=None):
    """The path (q[:, x], q[:, y]) of a Trajectory in the plane, with heading marks, the
    goal and obstacles.

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
        kept out (the sign of `OptimalControlProblem`'s path constraints g <= 0).
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
    """
    q = checks.instance("traj", traj, Trajectory, "a Trajectory").q
    x, y = checks.column("x", x, q.shape[1]), checks.column("y", y, q.shape[1])
    heading = None if heading is None else checks.column("heading", heading, q.shape[1])
    goal = None if goal is None else checks.array("goal", goal, (q.shape[1],), allow_nan=True)
    labels = checks.strings("labels", labels, 2)
    unit = units_of(units, q.shape[1], traj.u.shape[1] // len(traj.control_nodes))["q"]
    marks = checks.positive_int("marks", marks)
    fig, ax = single_axes(ax, height=5.2)
    ax.plot(q[:, x], q[:, y], "-", lw=1.2, color=color, label=name)
    shown = ax.get_legend_handles_labels()[1]
    ax.plot(q[0, x], q[0, y], "o", color="C2", label="_nolegend_" if "start" in shown else "start")
    ax.plot(q[-1, x], q[-1, y], "s", color="C3", mfc="none",
            label="_nolegend_" if "end" in shown else "end")
    length = max(np.ptp(q[:, x]), np.ptp(q[:, y]), 1e-9) / 12      # of a heading arrow
    if heading is not None:
        k = _evenly_along(q[:, [x, y]], marks)
        _arrows(ax, q[k, x], q[k, y], q[k, heading], length, color, label="heading")
    if goal is not None:
        _goal(ax, goal, x, y, heading, 1.5 * length)
    if obstacles is not None:
        draw_obstacles(ax, obstacles)
    ax.set_xlabel(label(labels[0], unit[x]))
    ax.set_ylabel(label(labels[1], unit[y]))
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.1)
    return finish(fig, ax, title)


def _goal(ax, goal, x, y, heading, length):
    """The goal: a star (with its heading) where both coordinates are given, a dotted line
    across the plane where one of them is free."""
    gx, gy = np.isfinite(goal[[x, y]])
    if gx and gy:
        ax.plot(goal[x], goal[y], "*", ms=14, color="C1", label="goal")
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


def draw_obstacles(ax, obstacles):
    """Draw `obstacles` into `ax`: an array (K, 3) of discs (x, y, radius) as patches, or a
    callable g(x, y) as the shaded region g > 0 with its edge g = 0.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Holding the path already (the region is shaded over its extent).
    obstacles : array_like, shape (K, 3), or callable
    """
    if callable(obstacles):
        _region(ax, obstacles)
        return
    discs = checks.real_array("obstacles", obstacles, "discs (x, y, radius), shape (K, 3), or "
                              "a callable g(x, y)")
    if discs.ndim == 1 and discs.size == 3:
        discs = discs[None, :]
    if discs.ndim != 2 or discs.shape[1] != 3:
        raise InputError(f"`obstacles` must be discs (x, y, radius), shape (K, 3), or a "
                         f"callable g(x, y); got shape {discs.shape}.")
    if not np.all(discs[:, 2] > 0):
        raise InputError(f"`obstacles` must have radii > 0 (the third column); got "
                         f"{discs[:, 2].tolist()}.")
    from matplotlib.patches import Circle

    for i, (x, y, r) in enumerate(discs):
        ax.add_patch(Circle((x, y), r, facecolor="0.75", edgecolor="0.35", lw=0.8, zorder=0,
                            label="_nolegend_" if i else "obstacle"))
    ax.update_datalim(np.r_[discs[:, :2] - discs[:, 2:], discs[:, :2] + discs[:, 2:]])


def _region(ax, g):
    """Shade {g(x, y) > 0} on a square grid around what `ax` holds, 1.5 times its extent
    (the equal aspect may widen the shorter side by that much)."""
    ax.autoscale_view()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    half = 0.75 * max(x1 - x0, y1 - y0)
    side = np.linspace(-half, half, _GRID)
    X, Y = np.meshgrid((x0 + x1) / 2 + side, (y0 + y1) / 2 + side)
    try:
        Z = np.broadcast_to(np.asarray(g(X, Y), dtype=float), X.shape)
    except Exception as err:  # the user's function: say what broke, naming it
        raise InputError(f"`obstacles` as a callable must map arrays x, y of shape {X.shape} "
                         f"to g(x, y) of that shape; it raised {type(err).__name__}: {err}") from None
    if not (Z > 0).any():
        return
    ax.contourf(X, Y, Z, levels=[0, np.inf], colors=["0.75"], zorder=0)
    ax.contour(X, Y, Z, levels=[0], colors=["0.35"], linewidths=0.8, zorder=0)
    from matplotlib.patches import Patch

    ax.add_artist(ax.legend(handles=[Patch(facecolor="0.75", edgecolor="0.35", label="kept out")],
                            loc="lower right", fontsize="small"))
