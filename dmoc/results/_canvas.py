"""The figures of the results stage, drawn cheaply: a bare Figure on the Agg canvas (no
pyplot), fixed margins instead of a layout engine (which measures every tick label again
at each save), plain tick labels on log axes (no mathtext), one resolution for every PNG;
and the axis labels with the units a system declares (`dmoc.mechanics.units`).
"""

import numpy as np

from .._util.files import atomic_write
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


def bound_lines(ax, lower, upper):
    """The finite entries of a scalar bound pair as dashed horizontal lines, one legend entry."""
    finite = [value for value in (lower, upper) if np.isfinite(value)]
    for i, value in enumerate(finite):
        ax.axhline(value, color="C3", ls="--", lw=0.9, label="_nolegend_" if i else "bound")


def save_png(fig, path):
    """Write `fig` as a PNG file at `path`, atomically (an old file stays whole on failure)."""
    with atomic_write(path) as file:
        fig.savefig(file, format="png", dpi=DPI, pil_kwargs={"compress_level": 1})
