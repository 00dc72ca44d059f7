"""A rigid body's motion on SO(3) x R^n_x as a GIF file (results stage): in 3-D, the path
of x drawn so far and the body's frame at each frame's knot (the axes of
`dmoc.results.body_figure.body_axes`), drawn on a bare Figure on the Agg canvas, the still
parts once and the moving ones per frame, written by Pillow (both imported lazily);
`dmoc.animation.animate_body`.
"""

import numpy as np

from ._canvas import DPI, save_gif
from .body_figure import AXIS_COLORS, axes_length, body_axes, cube_limits, frame_knots, positions_3d
from .._util import checks
from ..principle.rotation_trajectory import RotationTrajectory

def animate_body(traj, path, *, frames=40, fps=12, length=None, title=None):
    """Write an animation of a rigid body's motion on SO(3) x R^n_x to the GIF file `path`:
    in 3-D, the path of x drawn so far and the body's frame at the frame's knot, the axes
    from x_k to x_k + length R_k e_i (`dmoc.results.body_figure.body_axes`; red, green,
    blue), with the clock.

    Parameters
    ----------
    traj : RotationTrajectory
        Of a body whose x is a position (n_x = 0, 2 or 3, as `dmoc.plotting.plot_body`).
    path : str or pathlib.Path
        The GIF file to write; its folder is created if missing.
    frames : int
        Number of frames, 40 by default (knots subsampled evenly; at most traj.steps + 1).
    fps : int
        Frames per second.
    length : float, optional
        The axes' length (default: a quarter of the path's extent, 1 without a motion).
    title : str, optional

    Returns
    -------
    pathlib.Path
        The file written.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    checks.instance("traj", traj, RotationTrajectory, "a RotationTrajectory")
    path = checks.file_path("path", path)
    frames = min(checks.positive_int("frames", frames), traj.steps + 1)
    fps = checks.positive_float("fps", fps)
    x, length = positions_3d(traj), axes_length(traj, length)
    knots = frame_knots(traj.steps, frames)
    segments = body_axes(traj, knots, length)
    fig = Figure(figsize=(3.9, 3.6), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    limits = cube_limits(segments.reshape(-1, 3))
    ax.set(xlim=limits[0], ylim=limits[1], zlim=limits[2], xlabel="x", ylabel="y", zlabel="z",
           title=title or "")
    ax.set_box_aspect((1, 1, 1))
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):     # white panes: the palette keeps no grey tints
        axis.set_pane_color((1.0, 1.0, 1.0, 0.0))
    trail, = ax.plot([], [], [], color="0.3", lw=1, animated=True)
    axes = [ax.plot([], [], [], color=c, lw=2.5, animated=True)[0] for c in AXIS_COLORS]
    clock = ax.text2D(0.02, 0.95, "", transform=ax.transAxes, animated=True)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images = []
    for order, k in enumerate(knots):             # only the moving artists are drawn again
        fig.canvas.restore_region(background)
        trail.set_data_3d(*x[: k + 1].T)
        for line, segment_i in zip(axes, segments[order]):
            line.set_data_3d(*segment_i.T)
        clock.set_text(f"t = {traj.t[k]:.2f}")
        for artist in (trail, *axes, clock):
            ax.draw_artist(artist)
        images.append(np.array(fig.canvas.buffer_rgba())[..., :3])
    return save_gif(images, path, fps)
