"""The declared bodies of a system (`dmoc.Body`) as matplotlib artists, part of the results
stage: a filled polygon, a line or a marker per body, placed at a configuration and moved
to another (the path plot draws them at a few poses, an animation at every frame).
"""

import numpy as np

from .._util import checks
from ..errors import InputTypeError
from ..mechanics.bodies import Body


def body_values(bodies):
    """`bodies` checked: a tuple of Body (empty for None)."""
    if bodies is None:
        return ()
    if isinstance(bodies, Body) or not isinstance(bodies, (list, tuple)):
        raise InputTypeError(f"`bodies` must be a list or tuple of dmoc.Body (e.g. "
                         f"system.bodies); got {type(bodies).__name__}.")
    for i, body in enumerate(bodies):
        checks.instance(f"bodies[{i}]", body, Body, "a dmoc.Body")
    return tuple(bodies)


def body_color(body, i):
    """The colour of the i-th body: its own, or the cycle's from C1 on (C0 is the path's)."""
    return body.color or f"C{(i + 1) % 10}"


class DrawnBodies:
    """The artists of `bodies` at one configuration's outlines; `move` places them at
    another's (each outline evaluated once by `outlines`, never again here).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    bodies : tuple of Body
    points : list of ndarray, shape (k, 2)
        The outline of each body at the first configuration (one entry of `outlines`): a
        single point is a marker, a closed outline a polygon, an open one a line.
    alpha : float
        Opacity of the polygons' fill (edges, lines and markers are opaque).
    legend : bool
        Whether the bodies' names enter the legend.
    animated : bool
        Artists drawn by hand at each frame (`matplotlib.artist.Artist.set_animated`).

    Attributes
    ----------
    artists : list of matplotlib.artist.Artist
        One per body, with gid "body <name>".
    """

    def __init__(self, ax, bodies, points, *, alpha=0.35, legend=True, animated=False, zorder=1.5):
        from matplotlib.colors import to_rgba
        from matplotlib.patches import Polygon

        self.bodies, self.artists = bodies, []
        for i, (body, points) in enumerate(zip(bodies, points)):
            color = body_color(body, i)
            label = body.name if legend else "_nolegend_"
            if len(points) == 1:
                artist, = ax.plot(*points.T, "o", color=color, ms=6, label=label, zorder=zorder)
            elif body.closed:
                artist = Polygon(points, closed=True, facecolor=to_rgba(color, alpha),
                                 edgecolor=color, lw=1.0, label=label, zorder=zorder)
                ax.add_patch(artist)
            else:
                artist, = ax.plot(*points.T, "-", color=color, lw=2.5, solid_capstyle="butt",
                                  label=label, zorder=zorder)
            artist.set_gid(f"body {body.name}")
            artist.set_animated(animated)
            self.artists.append(artist)

    def move(self, points):
        """Place every body at its outline `points` (one entry of `outlines`)."""
        for artist, points in zip(self.artists, points):
            if hasattr(artist, "set_xy"):
                artist.set_xy(points)
            else:
                artist.set_data(*points.T)


def outlines(bodies, q):
    """The outlines of `bodies` at the configurations `q` (shape (K, n)): K lists of one
    array of shape (k, 2) per body, for `DrawnBodies` and the plots' limits alike."""
    return [[body.points(qk) for body in bodies] for qk in np.atleast_2d(q)]
