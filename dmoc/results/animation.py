"""Animations of computed trajectories as GIF files, the results stage of the pipeline:
a knife edge or Chaplygin sleigh drawn as a blade, the vertical rolling disk as a coin with
its heading and rolling mark, and a generic marker for any planar system. Drawn on a bare
Figure on the Agg canvas (never pyplot), the still parts once and the moving ones per
frame, and written by Pillow (both imported lazily).
"""

import numpy as np

from ._canvas import label, units_of
from .._util import checks
from .._util.files import atomic_path
from ..errors import InputError
from ..principle.trajectory import Trajectory

SHAPES = ("blade", "coin", "point")


def animate(traj, path, *, shape="point", x=0, y=1, heading=None, roll=None, goal=None,
            size=None, frames=40, fps=12, labels=("x", "y"), units=None, title=None):
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
        Number of frames, 40 by default (knots are subsampled evenly; at most traj.steps + 1).
    fps : int
        Frames per second.
    labels : pair of str
        Axis labels (the names of columns x and y).
    units : mapping, optional
        A system's `units` ({"t", "q", "u"}): those of x and y join the labels, that of
        t the clock ("t = 2.04 s").
    title : str, optional

    Returns
    -------
    pathlib.Path
        The file written.

    Notes
    -----
    The picture is sized to the motion's aspect (a wide motion gives a wide GIF, the
    ratio kept within 1:2). The axes, path limits and goal are drawn once; each frame
    redraws only the trail, the body and the clock over that background.
    """
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
    labels = checks.strings("labels", labels, 2)
    units = units_of(units, q.shape[1], traj.u.shape[1] // len(traj.control_nodes))
    path.parent.mkdir(parents=True, exist_ok=True)
    size = size or max(0.1, 0.1 * max(np.ptp(q[:, x]), np.ptp(q[:, y])))
    limits = _limits(q[:, x], q[:, y], goal, (x, y), size)
    fig, ax = _canvas(limits)
    trail, = ax.plot([], [], "-", color="C0", lw=1, animated=True)
    body = _Body(ax, shape, size)
    _frame_axes(ax, goal, (x, y), limits, [label(s, units["q"][c]) for s, c in zip(labels, (x, y))],
                title)
    clock = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", animated=True)
    knots = np.unique(np.linspace(0, traj.steps, frames).round().astype(int))
    _fit(fig, ax)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in knots:                               # only the moving artists are drawn again
        fig.canvas.restore_region(background)
        trail.set_data(q[: k + 1, x], q[: k + 1, y])
        body.move(q[k, x], q[k, y], None if heading is None else q[k, heading],
                  0.0 if roll is None else q[k, roll])
        clock.set_text(f"t = {traj.t[k]:.2f}" + (f" {units['t']}" if units["t"] else ""))
        for artist in (trail, *body.artists, clock):
            ax.draw_artist(artist)
        images.append(np.array(fig.canvas.buffer_rgba())[..., :3])
    images = _palette_images(images)
    with atomic_path(path) as temporary:
        images[0].save(temporary, format="GIF", save_all=True, append_images=images[1:],
                       duration=round(1000 / fps), loop=0)
    return path


_HEIGHT = 4.0                                  # inches of the longer side of the plot
_MARGINS = (0.75, 0.15, 0.55, 0.4)             # left, right, bottom, top, inches
_DPI = 80


def _limits(xs, ys, goal, columns, size):
    """((x0, x1), (y0, y1)) around the path and goal, the shorter side widened so that
    the ratio stays within 1:2 (a narrower picture leaves no room to read it)."""
    points_x, points_y = list(xs), list(ys)
    if goal is not None:
        g = np.asarray(goal, dtype=float)[list(columns)]
        if np.isfinite(g).all():
            points_x.append(g[0])
            points_y.append(g[1])
    pad = 1.5 * size
    (x0, x1), (y0, y1) = ((min(v) - pad, max(v) + pad) for v in (points_x, points_y))
    width, height = x1 - x0, y1 - y0
    grow_x, grow_y = max(0.0, height / 2 - width) / 2, max(0.0, width / 2 - height) / 2
    return (x0 - grow_x, x1 + grow_x), (y0 - grow_y, y1 + grow_y)


def _canvas(limits):
    """A Figure on the Agg canvas whose plot area has the aspect of `limits`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    (x0, x1), (y0, y1) = limits
    aspect = (y1 - y0) / (x1 - x0)
    w, h = (_HEIGHT, _HEIGHT * aspect) if aspect <= 1 else (_HEIGHT / aspect, _HEIGHT)
    left, right, bottom, top = _MARGINS
    fig = Figure(figsize=(w + left + right, h + bottom + top), dpi=_DPI)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=left / fig.get_figwidth(), right=1 - right / fig.get_figwidth(),
                        bottom=bottom / fig.get_figheight(), top=1 - top / fig.get_figheight())
    return fig, fig.add_subplot()


def _fit(fig, ax):
    """Widen the Figure where labels stick out of it (long tick labels), the plot area
    kept as it is."""
    box, drawn = fig.bbox, ax.get_tightbbox(fig.canvas.get_renderer())
    left, right = max(0.0, box.x0 - drawn.x0), max(0.0, drawn.x1 - box.x1)
    bottom, top = max(0.0, box.y0 - drawn.y0), max(0.0, drawn.y1 - box.y1)
    if left + right + bottom + top == 0:
        return
    pad = 4.0 if left or right else 0.0                      # pixels beside the labels
    area = ax.get_position().transformed(fig.transFigure)    # the plot area, pixels
    width, height = box.width + left + right + pad, box.height + bottom + top
    fig.set_size_inches(width / fig.dpi, height / fig.dpi)
    ax.set_position([(area.x0 + left + pad) / width, (area.y0 + bottom) / height,
                     area.width / width, area.height / height])


def _palette_images(frames):
    """The RGB frames as palette images (GIF frames) sharing the palette of the last one,
    which shows every colour (the whole trail, the body), without dithering."""
    from PIL import Image

    palette = Image.fromarray(frames[-1]).quantize(colors=64, method=Image.Quantize.FASTOCTREE)
    return [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]


def _frame_axes(ax, goal, columns, limits, labels, title):
    """Fixed limits, equal aspect, the goal and the labels."""
    if goal is not None:
        g = np.asarray(goal, dtype=float)[list(columns)]
        if np.isfinite(g).all():
            ax.plot(*g, "*", ms=14, color="C1", label="goal")
    ax.set_autoscale_on(False)
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
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
        self.artists = (self.outline, self.mark)
        for artist in self.artists:
            artist.set_animated(True)

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
