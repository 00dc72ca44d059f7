"""Figures of computed trajectories, the results stage of the pipeline: the path in the
plane, states and controls against time, the discrete constraint violation (28) and the
energy error on log scales, and convergence plots. matplotlib is imported lazily; every
function returns a `matplotlib.figure.Figure` (no pyplot state) and never shows it.
"""

import os

import numpy as np

from . import diagnostics
from .._util import checks
from .._util.files import atomic_write, make_folder
from ..errors import InputError
from ..discrete import Discretization
from ..principle.trajectory import Trajectory

_DPI = 120


def _figure(rows=1, *, width=6.0, height=4.0):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def _axes(ax):
    """A new Figure with one Axes, or the Figure of the given Axes."""
    if ax is None:
        fig, (ax,) = _figure()
        return fig, ax
    return ax.figure, ax


def _finish(fig, ax, title, legend=True):
    if title:
        ax.set_title(title)
    if legend and ax.get_legend_handles_labels()[0]:
        ax.legend()
    return fig


def plot_path(traj, *, x=0, y=1, heading=None, goal=None, labels=("x", "y"), marks=12,
              title=None, ax=None):
    """The path (q[:, x], q[:, y]) of a Trajectory in the plane, with heading marks.

    Parameters
    ----------
    traj : Trajectory
    x, y : int
        Columns of q plotted as the plane's coordinates.
    heading : int, optional
        Column of q holding the heading angle; arrows along it are drawn at `marks`
        evenly spaced knots (and at the goal).
    goal : array_like, shape (n,), optional
        Goal configuration; NaN entries (free) are not drawn.
    labels : pair of str
        Axis labels.
    marks : int
        Number of heading arrows along the path.
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
    marks = checks.positive_int("marks", marks)
    fig, ax = _axes(ax)
    ax.plot(q[:, x], q[:, y], "-", lw=1.2, color="C0", label="path")
    ax.plot(q[0, x], q[0, y], "o", color="C2", label="start")
    ax.plot(q[-1, x], q[-1, y], "s", color="C3", mfc="none", label="end")
    length = max(np.ptp(q[:, x]), np.ptp(q[:, y]), 1e-9) / 12      # of a heading arrow
    if heading is not None:
        k = _evenly_along(q[:, [x, y]], marks)
        _arrows(ax, q[k, x], q[k, y], q[k, heading], length, "C0", label="heading")
    if goal is not None:
        g = goal
        if np.isfinite(g[[x, y]]).all():
            ax.plot(g[x], g[y], "*", ms=14, color="C1", label="goal")
            if heading is not None and np.isfinite(g[heading]):
                _arrows(ax, g[[x]], g[[y]], g[[heading]], 1.5 * length, "C1")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.1)
    return _finish(fig, ax, title)


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


def plot_states(traj, *, names=None, title=None):
    """Each configuration coordinate q_k[i] against t_k, one panel per coordinate.

    Parameters
    ----------
    traj : Trajectory
    names : sequence of str, optional
        Names of the n coordinates (e.g. ``system.names``); default q0, q1, ...
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = checks.instance("traj", traj, Trajectory, "a Trajectory").q.shape[1]
    names = checks.strings("names", names, n) if names else [f"q{i}" for i in range(n)]
    fig, axes = _figure(n, height=1.1 + 1.1 * n)
    for i, ax in enumerate(axes):
        ax.plot(traj.t, traj.q[:, i], color=f"C{i}")
        ax.set_ylabel(names[i])
    axes[-1].set_xlabel("t")
    return _finish(fig, axes[0], title, legend=False)


def plot_controls(traj, *, names=None, title=None, ax=None):
    """The controls u(t) of a Trajectory against time: held controls as steps, controls at
    a stage rule's nodes as their interpolant on each step (`Trajectory.control`).

    Parameters
    ----------
    traj : Trajectory
    names : sequence of str, optional
        Names of the n_u controls (e.g. "torque"); default u0, u1, ...
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    n_u = traj.u.shape[1] // len(traj.control_nodes)
    names = checks.strings("names", names, n_u) if names else [f"u{i}" for i in range(n_u)]
    fig, ax = _axes(ax)
    if traj.control_nodes == (0.5,):
        for i, name in enumerate(names):
            ax.stairs(traj.u[:, i], traj.t, baseline=None, label=name)
    else:
        t = np.linspace(traj.t[0], traj.t[-1], 8 * traj.steps + 1)
        for i, name in enumerate(names):
            ax.plot(t, traj.control(t)[:, i], label=name)
    ax.set_xlabel("t")
    ax.set_ylabel("u")
    return _finish(fig, ax, title)


def _log_series(ax, t, values, label, empty="no values"):
    """Plot |values| on a log axis; exact zeros (invisible on it) are said in a note, and
    no values at all in the note `empty`."""
    values = np.abs(np.asarray(values, dtype=float))
    shown = np.where(values > 0, values, np.nan)
    ax.plot(t, shown, ".-", ms=2, lw=0.8, label=label)
    ax.set_yscale("log")
    if not np.isfinite(shown).any():
        ax.text(0.5, 0.5, "identically zero" if values.size else empty,
                transform=ax.transAxes, ha="center")
        ax.set_ylim(1e-17, 1e-15)
    ax.set_xlabel("t")


def plot_constraint_violation(disc, traj, *, title=None, ax=None):
    """The violation max_a abs(omega_d^a(q_k, q_{k+1})) of (28) at each step, log scale.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax)
    _log_series(ax, _midpoints(traj.t), diagnostics.constraint_violation(disc, traj),
                r"max$_a\,|\omega_d^a(q_k, q_{k+1})|$")
    ax.set_ylabel("constraint violation")
    return _finish(fig, ax, title)


def plot_energy_error(disc, traj, *, title=None, ax=None):
    """The energy error abs(E - E_0) on a log scale, E at the step midpoints
    (`diagnostics.energy`). A trajectory of one step has a single E and no change to show:
    the axes say so.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax)
    E = diagnostics.energy(disc, traj)
    _log_series(ax, _midpoints(traj.t)[1:], (E - E[0])[1:], r"$|E - E_0|$",
                empty="one step: a single energy E_0, no change to show (needs 2 steps)")
    ax.set_ylabel("energy error")
    return _finish(fig, ax, title)


def plot_convergence(h, errors, *, order=None, ylabel="error", title=None, ax=None):
    """Error against step size h on log-log axes, with a reference slope `order`.

    Parameters
    ----------
    h, errors : array_like, shape (K,)
        Step sizes and the errors measured with them.
    order : float, optional
        Draw the line C h^order through the smallest h.
    ylabel : str
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    h = checks.vector("h", h)
    errors = checks.vector("errors", errors, h.size, allow_nan=True)
    order = None if order is None else checks.finite_float("order", order)
    fig, ax = _axes(ax)
    ax.loglog(h, errors, "o-", label="measured")
    if order is not None:
        i = np.argmin(h)
        ax.loglog(h, errors[i] * (h / h[i]) ** order, "k--", lw=0.8, label=f"slope {order:g}")
    ax.set_xlabel("h")
    ax.set_ylabel(ylabel)
    return _finish(fig, ax, title)


def plot_cost_convergence(steps, costs, *, title=None, ax=None):
    """Optimal cost against the number of steps N (log N axis).

    Parameters
    ----------
    steps, costs : array_like, shape (K,)
        Numbers of steps N and the optimal costs J_N obtained with them.
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    steps = checks.vector("steps", steps)
    costs = checks.vector("costs", costs, steps.size, allow_nan=True)
    fig, ax = _axes(ax)
    ax.semilogx(steps, costs, "o-", label="optimal cost")
    ax.set_xlabel("N (steps)")
    ax.set_ylabel("cost")
    return _finish(fig, ax, title)


def save_trajectory_plots(traj, out, name, *, disc=None, names=None, control_names=None,
                          heading=None, goal=None):
    """Write the plots of `traj` as PNG files into the folder `out` (created if missing).

    Parameters
    ----------
    traj : Trajectory
    out : str or pathlib.Path
        Output folder, created with its missing parents; an InputError if it, or a folder
        above it, is a file.
    name : str
        Prefix of the files, without a path separator (the folders go into `out`):
        ``{name}_path.png`` (when n >= 2), ``{name}_states.png``,
        ``{name}_controls.png`` (when there are controls) and, given `disc`,
        ``{name}_constraint.png`` (when there are constraints) and ``{name}_energy.png``.
    disc : Discretization, optional
        Needed for the constraint-violation and energy plots.
    names, control_names : sequence of str, optional
        Names of the coordinates and of the controls.
    heading : int, optional
        Column of q holding the heading (see `plot_path`).
    goal : array_like, shape (n,), optional
        Goal configuration drawn on the path.

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
    checks.instance("disc", disc, (Discretization, type(None)), "a Discretization or None")
    out = make_folder("out", out)
    figures = {}
    if traj.q.shape[1] >= 2:
        labels = tuple(names[:2]) if names else ("x", "y")
        figures["path"] = plot_path(traj, heading=heading, goal=goal, labels=labels,
                                    title=f"{name}: path")
    figures["states"] = plot_states(traj, names=names, title=f"{name}: states")
    if traj.u.shape[1]:
        figures["controls"] = plot_controls(traj, names=control_names, title=f"{name}: controls")
    if disc is not None and traj.steps:
        if disc.system.m:
            figures["constraint"] = plot_constraint_violation(
                disc, traj, title=f"{name}: discrete constraint violation")
        energy = "energy change (controls do work)" if np.any(traj.u) else "energy error"
        figures["energy"] = plot_energy_error(disc, traj, title=f"{name}: {energy}")
    written = []
    for kind, fig in figures.items():
        written.append(out / f"{name}_{kind}.png")
        with atomic_write(written[-1]) as file:
            fig.savefig(file, format="png", dpi=_DPI)
    return written


def _midpoints(t):
    return (t[:-1] + t[1:]) / 2
