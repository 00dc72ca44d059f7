"""Obstacles and kept-out regions drawn on a path, part of the results stage: discs given
by centre and radius, or the region g(x, y) > 0 of a function on the plane (the sign of an
`OptimalControlProblem`'s path constraints g <= 0), shaded on a grid over the axes.
"""

import numpy as np

from .._util import checks
from ..errors import InputError

_GRID = 160     # points per side of the grid a region is shaded on


def draw_obstacles(ax, obstacles):
    """Draw `obstacles` into `ax`: an array (K, 3) of discs (x, y, radius) as patches, or a
    callable g(x, y) as the shaded region g > 0 with its edge g = 0.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Holding the path already (the region is shaded over its extent).
    obstacles : array_like, shape (K, 3), or callable
    """
    if callable(obstacles):
        _region(ax, obstacles)
        return
    discs = checks.real_array("obstacles", obstacles, "discs (x, y, radius), shape (K, 3), or "
                              "a callable g(x, y)")
    if discs.ndim == 1 and discs.size == 3:
        discs = discs[None, :]
    if discs.ndim != 2 or discs.shape[1] != 3:
        raise InputError(f"`obstacles` must be discs (x, y, radius), shape (K, 3), or a "
                         f"callable g(x, y); got shape {discs.shape}.")
    if not np.all(discs[:, 2] > 0):
        raise InputError(f"`obstacles` must have radii > 0 (the third column); got "
                         f"{discs[:, 2].tolist()}.")
    from matplotlib.patches import Circle

    for i, (x, y, r) in enumerate(discs):
        ax.add_patch(Circle((x, y), r, facecolor="0.75", edgecolor="0.35", lw=0.8, zorder=0,
                            label="_nolegend_" if i else "obstacle"))
    ax.update_datalim(np.r_[discs[:, :2] - discs[:, 2:], discs[:, :2] + discs[:, 2:]])


def _region(ax, g):
    """Shade {g(x, y) > 0} over the data limits of `ax`, widened by a fifth."""
    ax.autoscale_view()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    wx, wy = (x1 - x0) / 10, (y1 - y0) / 10
    X, Y = np.meshgrid(np.linspace(x0 - wx, x1 + wx, _GRID), np.linspace(y0 - wy, y1 + wy, _GRID))
    try:
        Z = np.broadcast_to(np.asarray(g(X, Y), dtype=float), X.shape)
    except Exception as err:  # the user's function: say what broke, naming it
        raise InputError(f"`obstacles` as a callable must map arrays x, y of shape {X.shape} "
                         f"to g(x, y) of that shape; it raised {type(err).__name__}: {err}") from None
    if not (Z > 0).any():
        return
    ax.contourf(X, Y, Z, levels=[0, np.inf], colors=["0.75"], zorder=0)
    ax.contour(X, Y, Z, levels=[0], colors=["0.35"], linewidths=0.8, zorder=0)
    from matplotlib.patches import Patch

    ax.add_artist(ax.legend(handles=[Patch(facecolor="0.75", edgecolor="0.35", label="kept out")],
                            loc="lower right", fontsize="small"))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
