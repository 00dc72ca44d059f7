"""Figures of computed trajectories, the results stage of the pipeline: the paths in the
plane with obstacles and goal, states and controls against time (one panel each, with
units and bounds), the discrete constraint violation (28), the energy error of a free
motion and the energy balance of a forced one, and convergence plots. matplotlib is
imported lazily; every function returns a `matplotlib.figure.Figure` (no pyplot state)
and never shows it.
"""

import os
import re

import numpy as np

from ._canvas import bound_lines, figure, finish, label, save_png, single_axes, units_of
from .diagnostic_plots import (control_work, plot_constraint_violation, plot_convergence,
                               plot_cost_convergence, plot_energy_balance, plot_energy_error)
from .obstacles import draw_obstacles
from .._util import checks
from .._util.files import make_folder
from ..discrete import Discretization
from ..errors import InputError
from ..optimize.problem import OptimalControlProblem
from ..principle.trajectory import Trajectory

__all__ = ["plot_path", "plot_states", "plot_controls", "plot_constraint_violation",
           "plot_energy_error", "plot_energy_balance", "control_work", "plot_convergence",
           "plot_cost_convergence", "planes", "save_trajectory_plots"]


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
    unit = units_of(units, q.shape[1], _n_controls(traj))["q"]
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


def plot_states(traj, *, names=None, units=None, bounds=None, title=None):
    """Each configuration coordinate q_k[i] against t_k, one panel per coordinate.

    Parameters
    ----------
    traj : Trajectory
    names : sequence of str, optional
        Names of the n coordinates (e.g. ``system.names``); default q0, q1, ...
    units : mapping, optional
        A system's `units` ({"t", "q", "u"}), shown in the axis labels.
    bounds : pair of array_like, shape (n,), optional
        (lower, upper), e.g. a problem's `state_bounds`; finite entries are dashed lines.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = checks.instance("traj", traj, Trajectory, "a Trajectory").q.shape[1]
    names = checks.strings("names", names, n) if names else [f"q{i}" for i in range(n)]
    units = units_of(units, n, _n_controls(traj))
    lower, upper = _bounds("bounds", bounds, n)
    fig, axs = figure(n, height=0.95 + 1.1 * n)
    for i, ax in enumerate(axs):
        ax.plot(traj.t, traj.q[:, i], color=f"C{i}")
        bound_lines(ax, lower[i], upper[i])
        ax.set_ylabel(label(names[i], units["q"][i]))
    axs[-1].set_xlabel(label("t", units["t"]))
    return finish(fig, axs[0], title, legend=False)


def plot_controls(traj, *, names=None, units=None, bounds=None, title=None, axes=None):
    """The controls u(t) of a Trajectory against time, one panel per control (controls of
    different units never share an axis): held controls as steps, controls at a stage
    rule's nodes as their interpolant on each step (`Trajectory.control`).

    Parameters
    ----------
    traj : Trajectory
    names : sequence of str, optional
        Names of the n_u controls (e.g. "torque"); default u0, u1, ...
    units : mapping, optional
        A system's `units` ({"t", "q", "u"}), shown in the axis labels.
    bounds : pair of array_like, shape (n_u,), optional
        (lower, upper), e.g. a problem's `control_bounds`; finite entries are dashed lines.
    title : str, optional
    axes : sequence of matplotlib.axes.Axes, optional
        n_u Axes of one Figure to draw into instead of a new Figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    n_u = _n_controls(traj)
    names = checks.strings("names", names, n_u) if names else [f"u{i}" for i in range(n_u)]
    units = units_of(units, traj.q.shape[1], n_u)
    lower, upper = _bounds("bounds", bounds, n_u)
    if axes is None:
        fig, axs = figure(max(n_u, 1), height=0.95 + 1.4 * max(n_u, 1))
    elif len(axes) != n_u:
        raise InputError(f"`axes` must be {n_u} Axes, one per control; got {len(axes)}.")
    else:
        fig, axs = axes[0].figure, list(axes)
    t = np.linspace(traj.t[0], traj.t[-1], 8 * traj.steps + 1)
    for i, (ax, name) in enumerate(zip(axs, names)):
        if traj.control_nodes == (0.5,):
            ax.stairs(traj.u[:, i], traj.t, baseline=None, color=f"C{i}")
        else:
            ax.plot(t, traj.control(t)[:, i], color=f"C{i}")
        bound_lines(ax, lower[i], upper[i])
        ax.set_ylabel(label(name, units["u"][i]))
        finish(fig, ax, None)
    axs[-1].set_xlabel(label("t", units["t"]))
    for ax in axs[:-1]:
        ax.set_xlabel("")
    return finish(fig, axs[0], title, legend=False)


def _n_controls(traj):
    return traj.u.shape[1] // len(traj.control_nodes)


def _bounds(name, bounds, size):
    """(lower, upper) as arrays of `size`, +-inf where not given."""
    if bounds is None:
        return np.full(size, -np.inf), np.full(size, np.inf)
    if len(bounds) != 2:
        raise InputError(f"`{name}` must be a pair (lower, upper) of arrays of shape ({size},); "
                         f"got {len(bounds)} entries.")
    pair = tuple(checks.real_array(f"{name}[{i}]", b) for i, b in enumerate(bounds))
    if any(b.shape != (size,) for b in pair):
        raise InputError(f"`{name}` must be a pair (lower, upper) of arrays of shape ({size},); "
                         f"got shapes {[b.shape for b in pair]}.")
    return pair


def planes(names):
    """The pairs of columns (x, y) of q that are positions in a plane, by name: "x", "y"
    and "x_<s>", "y_<s>" (several bodies); the default names q0, q1 give (0, 1).

    Parameters
    ----------
    names : sequence of str, shape (n,)

    Returns
    -------
    list of pair of int
        Empty when no coordinates name a plane (the LC circuit's charges).
    """
    names = list(names)
    found = [(i, names.index("y" + s[1:])) for i, s in enumerate(names)
             if re.fullmatch(r"x(_\w+)?", s) and "y" + s[1:] in names]
    default = len(names) >= 2 and names == [f"q{i}" for i in range(len(names))]
    return found or ([(0, 1)] if default else [])


def save_trajectory_plots(traj, out, name, *, disc=None, problem=None, names=None,
                          control_names=None, units=None, heading=None, goal=None,
                          obstacles=None):
    """Write the plots of `traj` as PNG files into the folder `out` (created if missing).

    Parameters
    ----------
    traj : Trajectory
    out : str or pathlib.Path
        Output folder, created with its missing parents; an InputError if it, or a folder
        above it, is a file.
    name : str
        Prefix of the files, without a path separator (the folders go into `out`):
        ``{name}_path.png`` (when coordinates name a plane, `planes`),
        ``{name}_states.png``, ``{name}_controls.png`` (when there are controls) and,
        given `disc`, ``{name}_constraint.png`` (when there are constraints) and
        ``{name}_energy.png`` (the energy error, or for a forced motion the balance
        E - E_0 - W).
    disc : Discretization, optional
        Needed for the constraint-violation and energy plots; its system gives the
        default `names` and `units`.
    problem : OptimalControlProblem, optional
        The problem `traj` solves: its discretization, goal and bounds are drawn.
    names, control_names : sequence of str, optional
        Names of the coordinates and of the controls.
    units : mapping, optional
        Units {"t", "q", "u"}; default the system's.
    heading : int, optional
        Column of q holding the heading (see `plot_path`).
    goal : array_like, shape (n,), optional
        Goal configuration drawn on the path; default the problem's.
    obstacles : array_like, shape (K, 3), or callable, optional
        Drawn on the path (see `plot_path`).

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    out = checks.file_path("out", out)
    checks.instance("name", name, str, "a str")
    if any(c in name for c in {"/", "\\", os.sep, os.altsep} - {None}):
        raise InputError(f"`name` must be a file-name prefix without a path separator; got "
                         f"{name!r} (give the folders in `out`, the prefix in `name`).")
    checks.instance("problem", problem, (OptimalControlProblem, type(None)),
                    "an OptimalControlProblem or None")
    disc = problem.disc if problem is not None and disc is None else disc
    checks.instance("disc", disc, (Discretization, type(None)), "a Discretization or None")
    system = disc.system if disc is not None else None
    names = names or (system.names if system else [f"q{i}" for i in range(traj.q.shape[1])])
    units = units if units is not None else system.units if system else None
    goal = problem.q_goal if goal is None and problem is not None else goal
    out = make_folder("out", out)
    figures = _figures(traj, name, disc, problem, names, control_names, units, heading, goal,
                       obstacles)
    written = []
    for kind, fig in figures.items():
        written.append(out / f"{name}_{kind}.png")
        save_png(fig, written[-1])
    return written


def _figures(traj, name, disc, problem, names, control_names, units, heading, goal, obstacles):
    """{kind: Figure} of `save_trajectory_plots`."""
    figures, t_unit = {}, units["t"] if units else ""
    paths = planes(names)
    for i, (x, y) in enumerate(paths):
        figures["path"] = plot_path(
            traj, x=x, y=y, heading=heading, goal=goal, labels=(names[x], names[y]),
            units=units, obstacles=obstacles if i == 0 else None, color=f"C{i}",
            name=f"{names[x]}, {names[y]}" if len(paths) > 1 else "path",
            title=f"{name}: path", ax=figures["path"].axes[0] if i else None)
    figures["states"] = plot_states(traj, names=names, units=units, title=f"{name}: states",
                                    bounds=problem.state_bounds if problem else None)
    if traj.u.shape[1]:
        figures["controls"] = plot_controls(
            traj, names=control_names, units=units, title=f"{name}: controls",
            bounds=problem.control_bounds if problem else None)
    if disc is not None and traj.steps:
        if disc.system.m:
            figures["constraint"] = plot_constraint_violation(
                disc, traj, time_unit=t_unit, title=f"{name}: discrete constraint violation")
        if np.any(traj.u):
            figures["energy"] = plot_energy_balance(
                disc, traj, time_unit=t_unit,
                title=f"{name}: energy balance (W: work of the controls)")
        else:
            figures["energy"] = plot_energy_error(disc, traj, time_unit=t_unit,
                                                  title=f"{name}: energy error")
    return figures
