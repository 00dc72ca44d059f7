"""A robot's base rolling on its wheels, for the mechanics stage: the base's planar pose
(x, y, theta) as the first three coordinates, its velocity in its own frame for the link
recursion (`link_recursion.energies`), and the rolling-without-slipping one-forms (27) of its
wheels, read from the URDF: each wheel's axle from its joint's axis and origin, its radius
from its link's <collision> (else <visual>) cylinder or declared, its contact point a radius
below its centre.
"""

import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ...errors import InputError, InputTypeError
from .link_recursion import REVOLUTE, placement, rpy_rotation

BASE_NAMES = ("x", "y", "theta")
BASE_UNITS = ("m", "m", "rad")
GEOMETRY_TOLERANCE = 1e-9    # m or rad: a horizontal axle, a centred cylinder, a common ground


@dataclass(frozen=True)
class Wheel:
    """One wheel of the base, in the base's frame.

    Attributes
    ----------
    joint : str
        The wheel's joint.
    index : int
        The joint's coordinate among the moving joints (q[3 + index] in the system's q).
    radius : float
        r > 0 (m).
    centre : ndarray, shape (3,)
        The wheel's centre in the base's frame (m).
    axle : ndarray, shape (3,)
        The joint's unit axis in the base's frame, horizontal: the wheel turns by +phi about
        it.
    """

    joint: str
    index: int
    radius: float
    centre: np.ndarray
    axle: np.ndarray


def base_velocity(q, v):
    """(w_0, v_0), shapes (3, 1): the angular velocity of the base and the velocity of its
    origin, in its own frame, at q = (x, y, theta, ...), v = (xdot, ydot, thetadot, ...):
    w_0 = (0, 0, thetadot), v_0 = R(theta)^T (xdot, ydot, 0)."""
    c, s = ca.cos(q[2]), ca.sin(q[2])
    return (ca.vertcat(0, 0, v[2]), ca.vertcat(c * v[0] + s * v[1], -s * v[0] + c * v[1], 0))


def world_position(q, point):
    """(x, y, 0) + R(theta) point, shape (3, 1): a point given in the base's frame, in the
    world's, at q = (x, y, theta, ...)."""
    c, s = ca.cos(q[2]), ca.sin(q[2])
    return ca.vertcat(q[0] + c * point[0] - s * point[1], q[1] + s * point[0] + c * point[1],
                      point[2])


def read_wheels(wheels, joints, links, text, path):
    """The Wheels named by `wheels`, checked against the file.

    Parameters
    ----------
    wheels : sequence of str or mapping of str to float or None
        The wheel joints; a mapping gives declared radii (None: read from the file).
    joints : tuple of Joint
        The moving joints, in the order of q after the base's three coordinates.
    links : tuple of Link
        The tree (`robot_system._tree`).
    text : str
        The file's XML.
    path : pathlib.Path
        For messages.

    Returns
    -------
    tuple of Wheel
    """
    declared = _declared_radii(wheels, joints)
    root = ElementTree.fromstring(text)
    names = [j.name for j in joints]
    found = []
    for name, radius in declared.items():
        index = names.index(name)
        i = next(k for k, link in enumerate(links) if link.index == index)
        found.append(_wheel(name, index, links, i, radius, root, path))
    _check_common_ground(found, path)
    return tuple(found)


def _declared_radii(wheels, joints):
    """{joint name: declared radius or None}, the names checked against the moving joints."""
    if isinstance(wheels, str) or not hasattr(wheels, "__iter__"):
        raise InputTypeError(f"`wheels` must be a sequence of wheel joint names or a mapping of "
                             f"them to radii; got {type(wheels).__name__}.")
    declared = dict(wheels) if hasattr(wheels, "keys") else dict.fromkeys(wheels)
    movable = {j.name: j for j in joints}
    unknown = [w for w in declared if w not in movable]
    if unknown or not declared or len(declared) < len(list(wheels)):
        raise InputError(f"`wheels` must name distinct moving joints of the robot, among "
                         f"{list(movable)}; got {list(wheels)}"
                         + (f" ({unknown} not among them)." if unknown else "."))
    for name, radius in declared.items():
        if movable[name].kind not in REVOLUTE:
            raise InputError(f"`wheels`: joint {name!r} is {movable[name].kind}; a wheel turns "
                             f"on a revolute or continuous joint.")
        if radius is not None and not (isinstance(radius, (int, float)) and radius > 0):
            raise InputError(f"`wheels`: the radius of {name!r} must be a number > 0 (m); got "
                             f"{radius!r}.")
    return declared


def _wheel(name, index, links, i, radius, root, path):
    """The Wheel of joint `name` carried by link `i` of the tree."""
    chain, k = [], links[i].parent
    while links[k].parent is not None:
        chain.append(k)
        k = links[k].parent
    moving = [links[j].name for j in chain if links[j].kind != "fixed"]
    if moving:
        raise InputError(f"wheel joint {name!r} of {str(path)!r}: the links between it and the "
                         f"base {links[k].name!r} must be fixed to the base; {moving} move.")
    # the joint's frame in the base's: the wheel's link at phi = 0 (q[index] = 0; its
    # parents are fixed, so no other q enters)
    R, o = (np.array(ca.evalf(x)) for x in placement(links, i, ca.DM.zeros(index + 1)))
    axle = R @ links[i].axis
    if abs(axle[2]) > GEOMETRY_TOLERANCE:
        raise InputError(f"wheel joint {name!r} of {str(path)!r}: its axis must be horizontal in "
                         f"the base's frame (the wheel rolls on the plane z = const); got "
                         f"{np.round(axle, 6).tolist()}.")
    centre = o[:, 0]
    if radius is None:
        radius, offset = _cylinder(root, links[i], name, path)
        centre = centre + R @ offset
    return Wheel(name, index, float(radius), centre, axle)


def _cylinder(root, link, joint, path):
    """(radius, centre (3,) in the link's frame) of the wheel link's <collision> cylinder
    (its <visual> one when it has no collision cylinder), checked to turn about the joint's
    axis. adam has parsed the file: its numbers are numbers."""
    element = next(e for e in root.iter("link") if e.get("name") == link.name)
    shapes = [(tag, shape) for tag in ("collision", "visual") for shape in element.iter(tag)
              if shape.find("geometry/cylinder") is not None]
    if not shapes:
        raise InputError(f"wheel joint {joint!r} of {str(path)!r}: its link {link.name!r} has no "
                         f"<collision> or <visual> <cylinder> to read the wheel's radius from; "
                         f"declare it: wheels={{{joint!r}: r}}.")
    tag, shape = shapes[0]
    radius = float(shape.find("geometry/cylinder").get("radius", "0"))
    origin = shape.find("origin")
    xyz, rpy = (np.array([float(x) for x in origin.get(key, "0 0 0").split()])
                if origin is not None else np.zeros(3) for key in ("xyz", "rpy"))
    along = rpy_rotation(rpy) @ np.array([0.0, 0.0, 1.0])          # a cylinder's axis is its z
    off_axis = xyz - (xyz @ link.axis) * link.axis
    if np.linalg.norm(np.cross(along, link.axis)) > GEOMETRY_TOLERANCE or \
            np.linalg.norm(off_axis) > GEOMETRY_TOLERANCE or not radius > 0:
        raise InputError(f"wheel joint {joint!r} of {str(path)!r}: the {tag} cylinder of link "
                         f"{link.name!r} must have a radius > 0, be centred on the joint's axis "
                         f"and turn about it (its axis along {link.axis.tolist()}); got radius "
                         f"{radius}, centre {xyz.tolist()}, axis {np.round(along, 6).tolist()}; "
                         f"declare the radius instead: wheels={{{joint!r}: r}}.")
    return radius, xyz


def _check_common_ground(wheels, path):
    """Every wheel's lowest point at one height in the base's frame: one ground plane."""
    heights = [w.centre[2] - w.radius for w in wheels]
    if max(heights) - min(heights) > GEOMETRY_TOLERANCE:
        detail = ", ".join(f"{w.joint!r} at z = {h:.6g}" for w, h in zip(wheels, heights))
        raise InputError(f"the wheels of {str(path)!r} must touch one ground plane (centre "
                         f"height minus radius equal); got {detail}.")


def rolling_rows(wheels, n_joints):
    """The independent rolling-without-slipping rows in the base's frame, and their names.

    Parameters
    ----------
    wheels : sequence of Wheel
    n_joints : int
        Number of moving joints.

    Returns
    -------
    B : ndarray, shape (m, 3 + n_joints)
        Rows on (u, w, thetadot, the joint rates), (u, w) the velocity of the base's origin
        in its own frame; A(q) = B diag(R(theta)^T, 1, I) on v = (xdot, ydot, thetadot, ...).
    names : tuple of str
        "<joint> rolls" or "<joint> does not slip sideways", one per row.

    Notes
    -----
    The wheel's material point at the contact, c - r e_z (c its centre), moves with

        (u, w, 0) + thetadot e_z x c - r phidot a x e_z = 0,

    a its axle. Its components along d = a x e_z (rolling: the base's point over the
    contact moves at r phidot) and along a (no side slip) are the rows, taken in this order,
    every rolling row first, a row kept when it is independent of those kept before (the
    wheels of one axle share one side-slip row).
    """
    rows, names = [], []
    e_z = np.array([0.0, 0.0, 1.0])
    for direction, what in (("rolls", "rolls"), ("side", "does not slip sideways")):
        for wheel in wheels:
            d = np.cross(wheel.axle, e_z) if direction == "rolls" else wheel.axle
            row = np.zeros(3 + n_joints)
            row[:2], row[2] = d[:2], d @ np.cross(e_z, wheel.centre)
            if direction == "rolls":
                row[3 + wheel.index] = -wheel.radius
            if np.linalg.matrix_rank(np.array(rows + [row]), tol=GEOMETRY_TOLERANCE) > len(rows):
                rows.append(row)
                names.append(f"{wheel.joint} {what}")
    return np.array(rows), tuple(names)


def rolling_constraints(B):
    """The constraint callable A(q) = B diag(R(theta)^T, 1, I) of `MechanicalSystem`, (m, n)."""
    def constraints(q):
        c, s = ca.cos(q[2]), ca.sin(q[2])
        B_ = ca.DM(B)     # B_u u + B_w w with (u, w) = (c xdot + s ydot, -s xdot + c ydot)
        return ca.horzcat(B_[:, 0] * c - B_[:, 1] * s, B_[:, 0] * s + B_[:, 1] * c, B_[:, 2:])
    return constraints
