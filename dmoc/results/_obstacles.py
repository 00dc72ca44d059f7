"""Obstacles in the plane, part of the results stage: discs by centre and radius, or the
region g(x, y) > 0 of a function on the plane (the sign of an `OptimalControlProblem`'s
path constraints g <= 0), their extent (which the plots' limits hold whole) and how they
are drawn on a path plot or an animation's background.
"""

import numpy as np

from .._util import checks
from ..errors import InputError

_GRID = 160     # points per side of the grid a kept-out region is sampled on
_REACH = 2.0    # a region is looked for this many box sides beyond the drawn box


def obstacle_values(obstacles):
    """`obstacles` checked: discs as an array of shape (K, 3), or the callable itself."""
    if obstacles is None or callable(obstacles):
        return obstacles
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
    return discs


def obstacle_extent(obstacles, box):
    """Points whose box holds every obstacle whole, shape (k, 2): the corners of the discs'
    boxes; for a region, the box of the grid points where g > 0 on a grid reaching a box
    side beyond `box` ((x0, y0), (x1, y1)) on every side, when that box stays inside the
    grid (an unbounded region, a wall, is shaded across the axes but sets no limit)."""
    if obstacles is None:
        return np.empty((0, 2))
    if not callable(obstacles):
        return np.r_[obstacles[:, :2] - obstacles[:, 2:], obstacles[:, :2] + obstacles[:, 2:]]
    (x0, y0), (x1, y1) = box
    side = max(x1 - x0, y1 - y0)
    X, Y, Z = _sampled(obstacles, (x0 - _REACH * side, x1 + _REACH * side),
                       (y0 - _REACH * side, y1 + _REACH * side))
    inside = Z > 0
    if not inside.any() or inside[[0, -1], :].any() or inside[:, [0, -1]].any():
        return np.empty((0, 2))
    step = np.array([X[0, 1] - X[0, 0], Y[1, 0] - Y[0, 0]])     # the edge lies within a step
    points = np.column_stack([X[inside], Y[inside]])
    return np.array([points.min(axis=0) - step, points.max(axis=0) + step])


def draw_obstacles(ax, obstacles):
    """Draw `obstacles` (of `obstacle_values`) into `ax`, below everything else: discs as
    patches, a region as the shaded set g > 0 with its edge g = 0 over the current limits
    of `ax` (set them first). The data limits of `ax` are left as they were."""
    if obstacles is None:
        return
    if not callable(obstacles):
        from matplotlib.patches import Circle

        for i, (x, y, r) in enumerate(obstacles):
            ax.add_patch(Circle((x, y), r, facecolor="0.75", edgecolor="0.35", lw=0.8,
                                zorder=0.5, label="_nolegend_" if i else "obstacle"))
        return
    kept = ax.dataLim.frozen()
    X, Y, Z = _sampled(obstacles, ax.get_xlim(), ax.get_ylim())
    if (Z > 0).any():
        ax.contourf(X, Y, Z, levels=[0, np.inf], colors=["0.75"], zorder=0.5)
        ax.contour(X, Y, Z, levels=[0], colors=["0.35"], linewidths=0.8, zorder=0.5)
        from matplotlib.patches import Patch

        ax.add_artist(ax.legend(handles=[Patch(facecolor="0.75", edgecolor="0.35",
                                               label="kept out")],
                                loc="lower right", fontsize="small"))
    ax.dataLim.set(kept)


def _sampled(g, xlim, ylim):
    """X, Y, g(X, Y) on a _GRID x _GRID grid over the rectangle xlim x ylim."""
    X, Y = np.meshgrid(np.linspace(*xlim, _GRID), np.linspace(*ylim, _GRID))
    try:
        Z = np.broadcast_to(np.asarray(g(X, Y), dtype=float), X.shape)
    except Exception as err:  # the user's function: say what broke, naming it
        raise InputError(f"`obstacles` as a callable must map arrays x, y of shape {X.shape} "
                         f"to g(x, y) of that shape; it raised {type(err).__name__}: {err}") from None
    return X, Y, Z
