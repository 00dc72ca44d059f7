"""A rigid body's motion on SO(3) x R^n_x drawn (results stage): in three dimensions, the
path of its position x with the body's frame, the columns R_k e_1, R_k e_2, R_k e_3 of its
rotations, drawn as three axes at a few knots; and against time, its body angular
velocity Omega(t), the velocity x'(t) and the controls. The values between the knots are
`RotationTrajectory.sample`'s, the knots' those stored.
"""

import numpy as np

from .._util import checks
from ..errors import InputError
from ..principle.rotation_trajectory import RotationTrajectory
from ._canvas import DPI, figure, finish, label

AXIS_COLORS = ("tab:red", "tab:green", "tab:blue")      # body axes e1, e2, e3


def frame_knots(steps, frames):
    """The knots at which `plot_body` draws the frame: `frames` knots nearest to even
    times from the first to the last, each once, shape (<= frames,)."""
    return np.unique(np.round(np.linspace(0, steps, frames)).astype(int))


def positions_3d(traj):
    """The body's positions in space, shape (N + 1, 3): x (n_x = 3), (x, y, 0) in the plane
    z = 0 (n_x = 2), or the origin for a body with a fixed point (n_x = 0)."""
    n_x = traj.x.shape[1]
    if n_x not in (0, 2, 3):
        raise InputError(f"`traj` must be of a body whose coordinates x are a position (n_x = 0, "
                         f"2 or 3) to be drawn in space; got n_x = {n_x}.")
    return np.hstack([traj.x, np.zeros((traj.steps + 1, 3 - n_x))])


def body_axes(traj, knots, length):
    """The segments of the body's axes at `knots` (K,): from x_k to x_k + length R_k e_i,
    shape (K, 3, 2, 3) (knot, axis i, end, coordinate), x_k in space (`positions_3d`)."""
    x = positions_3d(traj)[knots]
    tips = x[:, None, :] + length * np.transpose(traj.R[knots], (0, 2, 1))     # row i: R_k e_i
    return np.stack([np.broadcast_to(x[:, None, :], tips.shape), tips], axis=2)


def axes_length(traj, length):
    """`length` checked, or by default a quarter of the extent of the path of x (1
    without a motion)."""
    if length is not None:
        return checks.positive_float("length", length)
    x = positions_3d(traj)
    extent = float((x.max(axis=0) - x.min(axis=0)).max())
    return 0.25 * extent if extent > 0 else 1.0


def cube_limits(points):
    """Equal limits on x, y and z holding `points` (K, 3): ((x0, x1), (y0, y1), (z0, z1))."""
    low, high = points.min(axis=0), points.max(axis=0)
    middle, half = (low + high) / 2, max((high - low).max() / 2, 1e-9)
    return tuple((m - half, m + half) for m in middle)


def plot_body(traj, *, frames=5, length=None, title=None):
    """The path of a body's position in 3-D with its frame drawn as three axes at `frames`
    knots: from x_k, the segments to x_k + length R_k e_i, i = 1, 2, 3 (red, green, blue;
    the earlier knots lighter).

    Parameters
    ----------
    traj : RotationTrajectory
        Of a body with a fixed point (the frames at the origin), or with x in the plane
        (n_x = 2, drawn at z = 0: the Chaplygin sphere's centre) or in space (n_x = 3).
    frames : int, optional
        How many knots carry a frame (at least 1; the knots nearest to even times).
    length : float, optional
        The axes' length (default: a quarter of the path's extent, 1 without a motion).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        One 3-D Axes, equal scales; the axis at knot k of body axis i is the Line3D whose
        gid is ``"axis i at knot k"``, the path the line labelled "path of x". Never shown.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    checks.instance("traj", traj, RotationTrajectory, "a RotationTrajectory")
    frames = checks.positive_int("frames", frames)
    x, length = positions_3d(traj), axes_length(traj, length)
    fig = Figure(figsize=(6.4, 5.2), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    if traj.x.shape[1]:
        ax.plot(*x.T, color="0.3", lw=1.2, label="path of x")
    shown = frame_knots(traj.steps, frames)
    segments = body_axes(traj, shown, length)
    for order, k in enumerate(shown):
        alpha = 0.3 + 0.7 * (order + 1) / len(shown)
        for i, color in enumerate(AXIS_COLORS):
            line, = ax.plot(*segments[order, i].T, color=color, alpha=alpha, lw=2,
                            label=f"body axis e{i + 1}" if order == len(shown) - 1 else None)
            line.set_gid(f"axis {i} at knot {k}")
    limits = cube_limits(np.vstack([x, x[shown] + length, x[shown] - length]))
    ax.set(xlim=limits[0], ylim=limits[1], zlim=limits[2], xlabel="x", ylabel="y", zlabel="z")
    ax.set_box_aspect((1, 1, 1))
    ax.legend(fontsize="small", loc="upper left")
    ax.set_title(title or f"the body at {len(shown)} knots from t = {traj.t[0]:.3g} to {traj.t[-1]:.3g}")
    return fig


def plot_body_rates(traj, *, control_names=None, title=None):
    """The body angular velocity Omega(t), the velocity x'(t) of the coordinates and the
    controls u against time, one panel each: Omega and x' sampled 8 times per step
    (`RotationTrajectory.sample`), the controls held on their steps.

    Parameters
    ----------
    traj : RotationTrajectory
    control_names : sequence of str, shape (n_u,), optional
        Default u0, u1, ...
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        3 + n_x + n_u panels, in that order.
    """
    checks.instance("traj", traj, RotationTrajectory, "a RotationTrajectory")
    n_x, n_u = traj.x.shape[1], traj.u.shape[1]
    names = checks.strings("control_names", control_names, n_u) if control_names else [f"u{i}" for i in range(n_u)]
    if traj.steps == 0:
        raise InputError("`traj` must have at least one step to draw its rates.")
    t = np.linspace(traj.t[0], traj.t[-1], 8 * traj.steps + 1)
    v = traj.sample(t).v
    rows = 3 + n_x + n_u
    fig, axs = figure(rows, height=0.95 + 1.1 * rows)
    for i in range(3 + n_x):
        axs[i].plot(t, v[:, i], color=f"C{i}")
        axs[i].set_ylabel(f"Omega_{i + 1}" if i < 3 else f"x'_{i - 2}")
    for j in range(n_u):
        axs[3 + n_x + j].stairs(traj.u[:, j], traj.t, baseline=None, color=f"C{3 + n_x + j}")
        axs[3 + n_x + j].set_ylabel(names[j])
    axs[-1].set_xlabel(label("t", ""))
    return finish(fig, axs[0], title, legend=False)
