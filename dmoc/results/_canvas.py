"""The figures of the results stage, drawn cheaply: a bare Figure on the Agg canvas (no
pyplot), fixed margins instead of a layout engine (which measures every tick label again
at each save), plain tick labels on log axes (no mathtext), one resolution for every PNG;
and the axis labels with the units a system declares (`dmoc.mechanics.units`).
"""

import numpy as np

from .._util.files import atomic_path, atomic_write
from ..errors import InputError
from ..mechanics.units import system_units

DPI = 100
# margins in inches: room for tick labels such as -0.0025 and 1e-15, an axis label, a title
_LEFT, _RIGHT, _BOTTOM, _TOP, _GAP = 0.95, 0.2, 0.55, 0.4, 0.3


def figure(rows=1, *, width=6.4, height=None, sharex=True):
    """A Figure with `rows` Axes stacked (sharing t when `sharex`), its margins fixed.

    Returns
    -------
    matplotlib.figure.Figure, list of matplotlib.axes.Axes
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    height = height or 1.2 + 1.6 * rows
    fig = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, 1, sharex=sharex, squeeze=False)[:, 0]
    for ax in axes:                     # fewer ticks: each Tick is a costly set of artists
        ax.xaxis.set_major_locator(MaxNLocator(8, steps=[1, 2, 2.5, 5, 10]))
        ax.yaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
    fig.subplots_adjust(left=_LEFT / width, right=1 - _RIGHT / width, bottom=_BOTTOM / height,
                        top=1 - _TOP / height, hspace=_GAP * rows / (height - _BOTTOM - _TOP))
    return fig, list(axes)


def single_axes(ax, height=3.4):
    """A new Figure with one Axes (`height` inches tall), or the Figure of the given Axes."""
    if ax is None:
        fig, (ax,) = figure(height=height)
        return fig, ax
    return ax.figure, ax


def finish(fig, ax, title, legend=True):
    """Set the title, and a legend if any artist is labelled; return the Figure."""
    if title:
        ax.set_title(title, y=1.0, pad=5)      # a fixed place: no search past the tick labels
    if legend and ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small")
    return fig


def plain_log_ticks(ax):
    """Log-scale y ticks at most 6 decades, written 1e-15, without minor ticks: mathtext
    labels and the dozens of minor Tick objects dominate the cost of a small plot."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator

    ax.yaxis.set_major_locator(LogLocator(numticks=6))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:.0e}".replace("e-0", "e-")
                                               .replace("e+0", "e")))
    ax.yaxis.set_minor_locator(NullLocator())


def label(name, unit):
    """An axis label: "x [m]", or the name alone without a unit."""
    return f"{name} [{unit}]" if unit else name


def units_of(units, n, n_u):
    """`units` (a system's mapping {"t", "q", "u"}, or None) checked against a trajectory
    of n coordinates and n_u controls; every key present ("" where none is given)."""
    problems = []
    declared = system_units(units, n, n_u, problems)
    if problems:
        raise InputError("`units` is invalid for this trajectory:\n  - " + "\n  - ".join(problems))
    return declared


# A plane plot is drawn to scale (equal aspect) unless its box is more than ASPECT_LIMIT
# times as long as it is wide: a 100 m lane change 3.5 m wide keeps its own scale across;
# a straight run (no width) counts as 1/THINNEST of its length wide.
ASPECT_LIMIT, THINNEST = 4.0, 50.0
_PLANE_MARGIN = 0.06        # of the box's side, on each side


def plane_limits(points):
    """The limits of a plot of the plane holding `points`, and whether it is to scale.

    Parameters
    ----------
    points : array_like, shape (k, 2)
        Every point drawn (path, goal, bodies, obstacle extents), NaN rows ignored.

    Returns
    -------
    (x0, x1), (y0, y1) : pair of float
    to_scale : bool
        True when the longer side of the points' box is at most ASPECT_LIMIT times the
        shorter (equal aspect); the limits then add the same margin to both sides.
    """
    points = np.asarray(points, dtype=float)
    points = points[np.isfinite(points).all(axis=1)]
    lower, upper = points.min(axis=0), points.max(axis=0)
    longer = max(np.max(upper - lower), 1e-9 * max(1.0, np.abs(points).max()))
    size = np.maximum(upper - lower, longer / THINNEST)
    to_scale = bool(size.min() * ASPECT_LIMIT >= longer)
    pad = _PLANE_MARGIN * (np.full(2, size.max()) if to_scale else size)
    middle = (lower + upper) / 2
    low, high = middle - size / 2 - pad, middle + size / 2 + pad
    return (low[0], high[0]), (low[1], high[1]), to_scale


def not_to_scale_note(ax):
    """A note in the corner of a plane plot whose axes have different scales."""
    ax.text(0.99, 0.01, "not to scale", transform=ax.transAxes, ha="right", va="bottom",
            fontsize="x-small", color="0.4")


def data_limits_with_bounds(ax, data, lower, upper):
    """Set the y limits of `ax` from `data` (with a margin) and draw the finite bounds
    within reach of the data as dashed lines, one legend entry; a bound farther than one
    span of the data from it (a +-15 kN bound over a +-1.5 kN ramp) is not drawn, which
    would squeeze the data to a line, but named in a note. Returns the bounds drawn."""
    data = np.asarray(data, dtype=float)
    data = data[np.isfinite(data)]
    low, high = (data.min(), data.max()) if data.size else (0.0, 0.0)
    span = high - low or max(abs(low), abs(high), 1.0) * 0.1
    finite = [b for b in (lower, upper) if np.isfinite(b)]
    drawn = [b for b in finite if low - span <= b <= high + span]
    for i, value in enumerate(drawn):
        ax.axhline(value, color="C3", ls="--", lw=0.9, label="_nolegend_" if i else "bound")
    shown = [low, high, *drawn]
    pad = 0.06 * (max(shown) - min(shown) or span)
    ax.set_ylim(min(shown) - pad, max(shown) + pad)
    far = [b for b in finite if b not in drawn]
    if far:
        ax.text(0.99, 0.97, "bound " + ", ".join(f"{b:.4g}" for b in far) + " off the axes",
                transform=ax.transAxes, ha="right", va="top", fontsize="x-small", color="C3")
    return drawn


def save_png(fig, path):
    """Write `fig` as a PNG file at `path`, atomically (an old file stays whole on failure)."""
    with atomic_write(path) as file:
        fig.savefig(file, format="png", dpi=DPI, pil_kwargs={"compress_level": 1})


def palette_images(frames):
    """The RGB frames as palette images (GIF frames) sharing the palette of the last one,
    which shows every colour (the whole trail, the body), without dithering."""
    from PIL import Image

    palette = Image.fromarray(frames[-1]).quantize(colors=64, method=Image.Quantize.FASTOCTREE)
    return [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]


def save_gif(frames, path, fps):
    """Write the RGB `frames` (each (height, width, 3) uint8) as a looping GIF at `path`
    (a pathlib.Path), `fps` frames a second, atomically (`palette_images`); returns `path`."""
    images = palette_images(frames)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:
        images[0].save(temporary, format="GIF", save_all=True, append_images=images[1:],
                       duration=round(1000 / fps), loop=0)
    return path
