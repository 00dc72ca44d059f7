"""States and controls against time, part of the results stage: one panel per coordinate
and per control (controls of different units never share an axis), labelled with the
system's units; the y limits from the data, the finite bounds of a problem within reach
of the data as dashed lines (`data_limits_with_bounds`).
"""

import numpy as np

from ._canvas import data_limits_with_bounds, figure, finish, label, units_of
from .._util import checks
from ..errors import InputError
from ..principle.trajectory import Trajectory


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
        (lower, upper), e.g. a problem's `state_bounds`; finite entries within one span of
        the data from it are dashed lines (the limits are the data's; a far bound is named
        in a note).
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
        data_limits_with_bounds(ax, traj.q[:, i], lower[i], upper[i])
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
        (lower, upper), e.g. a problem's `control_bounds`; drawn as for `plot_states`.
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
            data_limits_with_bounds(ax, traj.u[:, i], lower[i], upper[i])
        else:
            u = traj.control(t)[:, i]
            ax.plot(t, u, color=f"C{i}")
            data_limits_with_bounds(ax, u, lower[i], upper[i])
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
