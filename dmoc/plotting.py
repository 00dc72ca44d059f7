"""Plots of trajectories (matplotlib, imported lazily). Every function returns a Figure and
never calls plt.show()."""

import numpy as np


def _figure(ncols=1, width=5.0):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width * ncols, 4.0), layout="constrained")
    return fig, [fig.add_subplot(1, ncols, i + 1) for i in range(ncols)]


def plot_path(traj, *, x=0, y=1, labels=("x", "y"), title=None, ax=None):
    """The path (q[:, x], q[:, y]) of a Trajectory in the plane; returns the Figure."""
    fig, (ax,) = _figure() if ax is None else (ax.figure, (ax,))
    ax.plot(traj.q[:, x], traj.q[:, y], ".-", ms=3)
    ax.plot(traj.q[0, x], traj.q[0, y], "go", label="start")
    ax.plot(traj.q[-1, x], traj.q[-1, y], "rs", label="end")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend()
    if title:
        ax.set_title(title)
    return fig


def plot_controls(traj, *, names=None, title=None, ax=None):
    """The piecewise-constant controls u_k of a Trajectory against time; returns the Figure."""
    fig, (ax,) = _figure() if ax is None else (ax.figure, (ax,))
    names = names or [f"u{i}" for i in range(traj.u.shape[1])]
    for i, name in enumerate(names):
        ax.stairs(traj.u[:, i], traj.t, baseline=None, label=name)
    ax.set_xlabel("t")
    ax.legend()
    if title:
        ax.set_title(title)
    return fig


def plot_series(t, series, *, ylabel, logy=False, title=None, ax=None):
    """Named series {label: values} against t (e.g. energy or constraint violation)."""
    fig, (ax,) = _figure() if ax is None else (ax.figure, (ax,))
    for label, values in series.items():
        values = np.asarray(values)
        ax.plot(t[: len(values)], np.abs(values) if logy else values, label=label)
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel("t")
    ax.set_ylabel(ylabel)
    ax.legend()
    if title:
        ax.set_title(title)
    return fig


def save_trajectory_plots(traj, out, name, *, control_names=None):
    """Write `{name}_path.png` and `{name}_controls.png` of `traj` into the folder `out`."""
    plot_path(traj, title=f"{name}: path").savefig(out / f"{name}_path.png", dpi=120)
    plot_controls(traj, names=control_names, title=f"{name}: controls").savefig(
        out / f"{name}_controls.png", dpi=120)
