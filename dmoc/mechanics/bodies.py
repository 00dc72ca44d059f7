"""The bodies of a system as they are drawn, part of the mechanics stage: each a named
outline in the plane (a polygon, a polyline or a point) as a function of the
configuration q, declared once with the system (``bodies=(Body("blade", ...),)``) and
drawn by the results stage on the path plot and in every frame of an animation.
"""

import numpy as np

from ..errors import InputError, InputTypeError


class Body:
    """A body to draw: its outline in the plane of the motion as a function of q.

    Parameters
    ----------
    name : str
        Shown in the legend, e.g. "trailer"; the bodies of a system have distinct names.
    outline : callable
        ``outline(q)`` with q a NumPy array of shape (n,), returning the points of the
        outline in the plane, array_like of shape (k, 2): (x, y) in the units of the
        plane's coordinates (those of the path plot). A single point (k = 1) is drawn
        as a marker.
    closed : bool
        True: a filled polygon through the points (a truck's box); False: a line through
        them (a blade, a wheel seen from above, an axle).
    color : str, optional
        A matplotlib colour; default one of the cycle by the body's place in the system.

    Examples
    --------
    >>> import numpy as np
    >>> blade = Body("blade", lambda q: segment(q[:2], q[2], 0.3), closed=False)
    >>> blade.points(np.array([1.0, 2.0, 0.0]))
    array([[0.85, 2.  ],
           [1.15, 2.  ]])
    """

    def __init__(self, name, outline, *, closed=True, color=None):
        if not isinstance(name, str) or not name or "\n" in name:
            raise InputError(f"`name` of a Body must be a non-empty line of text; got {name!r}.")
        if not callable(outline):
            raise InputTypeError(f"`outline` of Body {name!r} must be a callable q -> points "
                             f"(k, 2); got {type(outline).__name__}.")
        if not isinstance(closed, (bool, np.bool_)):
            raise InputTypeError(f"`closed` of Body {name!r} must be True or False; got {closed!r}.")
        if color is not None and not isinstance(color, str):
            raise InputTypeError(f"`color` of Body {name!r} must be a matplotlib colour name or "
                             f"None; got {color!r}.")
        self.name, self.outline, self.closed, self.color = name, outline, bool(closed), color

    def points(self, q):
        """The outline at the configuration `q` (shape (n,)), an array of shape (k, 2).

        Raises
        ------
        InputError
            When `outline` raises or returns anything but finite points of shape (k, 2),
            naming the body.
        """
        try:
            points = np.asarray(self.outline(np.asarray(q, dtype=float)), dtype=float)
        except Exception as err:  # the user's function: say what broke, naming the body
            raise InputError(f"`outline` of Body {self.name!r} must map q of shape "
                             f"({np.size(q)},) to points (k, 2); it raised "
                             f"{type(err).__name__}: {err}") from None
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 1:
            raise InputError(f"`outline` of Body {self.name!r} must return points of shape "
                             f"(k, 2), k >= 1; got shape {points.shape}.")
        if not np.isfinite(points).all():
            raise InputError(f"`outline` of Body {self.name!r} returned non-finite points at "
                             f"q = {np.asarray(q).tolist()}.")
        return points

    def __repr__(self):
        return f"Body({self.name!r}, closed={self.closed})"


def heading_axes(heading):
    """The unit vectors along the direction at angle `heading` and across it (turned a
    quarter turn counter-clockwise), each of shape (2,)."""
    return (np.array([np.cos(heading), np.sin(heading)]),
            np.array([-np.sin(heading), np.cos(heading)]))


def rectangle(centre, heading, length, width):
    """The corners of a rectangle in the plane, shape (4, 2): centred at `centre` (2,), its
    `length` along the direction at angle `heading` and its `width` across it."""
    e, n = heading_axes(heading)
    e, n = e * length / 2, n * width / 2
    return np.asarray(centre, dtype=float) + np.array([-e - n, e - n, e + n, -e + n])


def segment(centre, heading, length):
    """The two ends of a segment in the plane, shape (2, 2): centred at `centre` (2,), of
    `length` along the direction at angle `heading`."""
    e = heading_axes(heading)[0] * length / 2
    return np.asarray(centre, dtype=float) + np.array([-e, e])


def system_bodies(bodies, n, problems):
    """The bodies of a system as a tuple of Body, each outline tried at q = 0 (shape (n,));
    every problem is appended to `problems` (the system reports them at once)."""
    if bodies is None:
        return ()
    if isinstance(bodies, Body) or not isinstance(bodies, (list, tuple)):
        problems.append(f"`bodies` must be a list or tuple of dmoc.Body; got "
                        f"{type(bodies).__name__} (wrap one body as (body,)).")
        return ()
    wrong = [i for i, b in enumerate(bodies) if not isinstance(b, Body)]
    if wrong:
        problems.append(f"`bodies` must hold dmoc.Body values only; entries {wrong} are not.")
        return ()
    names = [b.name for b in bodies]
    repeated = sorted({s for s in names if names.count(s) > 1})
    if repeated:
        problems.append(f"`bodies` must have distinct names (legend entries); got {repeated} "
                        f"more than once.")
    for i, body in enumerate(bodies):
        try:
            body.points(np.zeros(n))
        except InputError as err:
            problems.append(f"`bodies[{i}]`: {err} (tried at q = 0)")
    return tuple(bodies)
