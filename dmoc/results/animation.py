"""Animations of computed trajectories as GIF files, the results stage of the pipeline:
the bodies a system declares (`dmoc.Body`) at every frame, or one of three stock shapes
(a blade, a coin with its rolling mark, a marker), over the obstacles and the goal; a
rigid body on SO(3) as its frame in 3-D (`animate_body`). Drawn
on a bare Figure on the Agg canvas (never pyplot), the still parts once and the moving ones
per frame, and written by Pillow (both imported lazily).
"""

import numpy as np

from ._canvas import label, not_to_scale_note, plane_limits, save_gif, units_of
from .body_animation import animate_body
from ._drawn_bodies import DrawnBodies, body_values, outlines
from ._obstacles import draw_obstacles, obstacle_extent, obstacle_values
from .._util import checks
from ..errors import InputError
from ..mechanics.bodies import Body, heading_axes, segment
from ..principle.trajectory import Trajectory

SHAPES = ("blade", "coin", "point")


def animate(traj, path, *, bodies=None, shape=None, x=0, y=1, heading=None, roll=None,
            goal=None, obstacles=None, size=None, frames=40, fps=12, labels=("x", "y"),
            units=None, title=None):
    """Write an animation of the planar motion of `traj` to the GIF file `path`.

    Parameters
    ----------
    traj : Trajectory
    path : str or pathlib.Path
        The GIF file to write; its folder is created if missing.
    bodies : sequence of Body, optional
        The bodies drawn at every frame (``system.bodies``), their outlines in the plane
        of columns x and y. Give `bodies` or `shape`, not both.
    shape : {"blade", "coin", "point"}, optional
        A stock body when the system declares none: "blade", a segment along the heading
        (knife edge, sleigh); "coin", the rolling disk seen obliquely from above, a mark on
        its rim turning with the rolling angle; "point" (the default without `bodies`), a
        marker, with a heading arrow when `heading` is given.
    x, y : int
        Columns of q holding the position in the plane.
    heading : int, optional
        Column of q holding the heading angle (required for "blade" and "coin").
    roll : int, optional
        Column of q holding the rolling angle ("coin" only).
    goal : array_like, shape (n,), optional
        Goal configuration drawn as a star; NaN entries are free.
    obstacles : array_like, shape (K, 3), or callable, optional
        Discs (x, y, radius) or a region g(x, y) > 0, drawn as by `plot_path`, whole.
    size : float, optional
        Length of a stock shape; default a tenth of the path's extent (at least 0.1).
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
    The limits hold the path, the goal, the bodies at every frame and the obstacles whole.
    The picture is to scale, sized to the motion's aspect (the ratio kept within 1:2),
    unless the motion is more than 4 times as long as it is wide (the rule of `plot_path`):
    then it is 2:1 and says "not to scale". The axes, obstacles and goal are drawn once;
    each frame redraws only the trail, the bodies and the clock over that background.
    """
    q = checks.instance("traj", traj, Trajectory, "a Trajectory").q
    path = checks.file_path("path", path)
    x, y = checks.column("x", x, q.shape[1]), checks.column("y", y, q.shape[1])
    heading = None if heading is None else checks.column("heading", heading, q.shape[1])
    roll = None if roll is None else checks.column("roll", roll, q.shape[1])
    goal = None if goal is None else checks.array("goal", goal, (q.shape[1],), allow_nan=True)
    size = None if size is None else checks.positive_float("size", size)
    frames = min(checks.positive_int("frames", frames), traj.steps + 1)
    fps = checks.positive_float("fps", fps)
    labels = checks.strings("labels", labels, 2)
    units = units_of(units, q.shape[1], traj.u.shape[1] // len(traj.control_nodes))
    obstacles, bodies = obstacle_values(obstacles), body_values(bodies)
    if bodies and shape is not None:
        raise InputError(f"give `bodies` or `shape`, not both; got shape={shape!r} and "
                         f"{len(bodies)} bodies.")
    size = size or max(0.1, 0.1 * max(np.ptp(q[:, x]), np.ptp(q[:, y])))
    bodies = bodies or _stock_bodies(checks.choice("shape", shape or "point", SHAPES),
                                     x, y, heading, roll, size)
    knots = np.unique(np.linspace(0, traj.steps, frames).round().astype(int))
    g = None if goal is None else goal[[x, y]]
    drawn_at = outlines(bodies, q[knots])         # each frame's outlines, evaluated once
    shown = np.concatenate([q[:, [x, y]], *[p for frame in drawn_at for p in frame],
                            g[None] if g is not None and np.isfinite(g).all() else np.empty((0, 2))])
    box = np.array([shown.min(axis=0), shown.max(axis=0)])
    xlim, ylim, to_scale = plane_limits(np.r_[box, obstacle_extent(obstacles, box)])
    fig, ax = _canvas(_widened((xlim, ylim)) if to_scale else (xlim, ylim), to_scale)
    draw_obstacles(ax, obstacles)
    _frame_axes(ax, g, [label(s, units["q"][c]) for s, c in zip(labels, (x, y))], title)
    trail, = ax.plot([], [], "-", color="C0", lw=1, animated=True, zorder=2)
    drawn = DrawnBodies(ax, bodies, drawn_at[0], alpha=0.5, legend=False, animated=True, zorder=3)
    clock = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", animated=True)
    _fit(fig, ax)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    images = []
    for k, points in zip(knots, drawn_at):        # only the moving artists are drawn again
        fig.canvas.restore_region(background)
        trail.set_data(q[: k + 1, x], q[: k + 1, y])
        drawn.move(points)
        clock.set_text(f"t = {traj.t[k]:.2f}" + (f" {units['t']}" if units["t"] else ""))
        for artist in (trail, *drawn.artists, clock):
            ax.draw_artist(artist)
        images.append(np.array(fig.canvas.buffer_rgba())[..., :3])
    return save_gif(images, path, fps)


_HEIGHT = 4.0                                  # inches of the longer side of the plot
_MARGINS = (0.75, 0.15, 0.55, 0.4)             # left, right, bottom, top, inches
_DPI = 80


def _widened(limits):
    """`limits` ((x0, x1), (y0, y1)) with the shorter side widened so that the ratio stays
    within 1:2 (a narrower picture leaves no room to read it)."""
    (x0, x1), (y0, y1) = limits
    width, height = x1 - x0, y1 - y0
    grow_x, grow_y = max(0.0, height / 2 - width) / 2, max(0.0, width / 2 - height) / 2
    return (x0 - grow_x, x1 + grow_x), (y0 - grow_y, y1 + grow_y)


def _canvas(limits, to_scale=True):
    """A Figure on the Agg canvas whose plot area has the aspect of `limits` when
    `to_scale`, else 2:1 along the longer side; the Axes holds the limits, fixed."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    (x0, x1), (y0, y1) = limits
    aspect = (y1 - y0) / (x1 - x0)
    if not to_scale:
        aspect = 0.5 if aspect <= 1 else 2.0
    w, h = (_HEIGHT, _HEIGHT * aspect) if aspect <= 1 else (_HEIGHT / aspect, _HEIGHT)
    left, right, bottom, top = _MARGINS
    fig = Figure(figsize=(w + left + right, h + bottom + top), dpi=_DPI)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=left / fig.get_figwidth(), right=1 - right / fig.get_figwidth(),
                        bottom=bottom / fig.get_figheight(), top=1 - top / fig.get_figheight())
    ax = fig.add_subplot()
    ax.set_autoscale_on(False)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    if to_scale:
        ax.set_aspect("equal", adjustable="box")
    else:
        not_to_scale_note(ax)
    return fig, ax


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


def _frame_axes(ax, goal, labels, title):
    """The goal ((x, y), drawn where both are given) and the labels."""
    if goal is not None and np.isfinite(goal).all():
        ax.plot(*goal, "*", ms=14, color="C1", label="goal", zorder=1)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    if title:
        ax.set_title(title)


def _stock_bodies(shape, x, y, heading, roll, size):
    """The bodies of a stock `shape` ("blade", "coin", "point") of length `size`, reading
    the position from columns x, y, the heading and the rolling angle from theirs."""
    if shape != "point" and heading is None:
        raise InputError(f"`heading` must be a column of q for shape {shape!r}; got None.")
    r = size / 2

    def ahead(q):                                   # the unit vector along the heading
        return heading_axes(q[heading])[0]

    if shape == "blade":
        return (Body("blade", lambda q: segment(q[[x, y]], q[heading], size), closed=False,
                     color="k"),
                Body("leading end", lambda q: (q[[x, y]] + r * ahead(q))[None], color="C3"))
    if shape == "coin":
        s = np.linspace(0, 2 * np.pi, 41)

        def rim(q):                                 # seen obliquely: the normal squashed
            e, n = heading_axes(q[heading])
            return q[[x, y]] + r * np.outer(np.cos(s), e) + 0.3 * r * np.outer(np.sin(s), n)

        def spoke(q):
            e, n = heading_axes(q[heading])
            angle = 0.0 if roll is None else q[roll]
            return np.array([q[[x, y]], q[[x, y]] - r * np.sin(angle) * e + 0.3 * r * np.cos(angle) * n])

        return (Body("coin", rim, color="goldenrod"),
                Body("rim mark", spoke, closed=False, color="C3"))
    point = (Body("position", lambda q: q[None, [x, y]], color="C0"),)
    if heading is None:
        return point
    return point + (Body("heading", lambda q: np.array([q[[x, y]], q[[x, y]] + r * ahead(q)]),
                         closed=False, color="C3"),)

