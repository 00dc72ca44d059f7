"""What a URDF file says about a robot's joints, for the mechanics stage: the movable joints
in the file's order, their limits (position, velocity, effort) and their viscous damping,
read with the standard library's XML parser; and the file's text with the elements the URDF
specification lets a file omit written out (a joint's or an inertial's <origin>, a joint's
<axis>), which adam 0.5 requires; the joints a robot moves and their friction, chosen among
them. The inertial data are read by adam
(`dmoc.mechanics.robots.robot_system`), not here.
"""

import math
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass

import numpy as np

from ..._util import checks
from ..._util.files import readable_file
from ...errors import InputError, InputTypeError

# joint types of a fixed-base robot that move (URDF specification, <joint type=...>) and the
# unit of their coordinate and of their actuator's effort
MOVABLE = {"revolute": ("rad", "N m"), "continuous": ("rad", "N m"), "prismatic": ("m", "N")}
FIXED = "fixed"


@dataclass(frozen=True)
class Joint:
    """One movable joint of a URDF.

    Attributes
    ----------
    name : str
    kind : str
        "revolute", "continuous" or "prismatic".
    lower, upper : float
        Position limits (rad or m); -inf and inf for a continuous joint.
    velocity, effort : float
        Velocity and effort limits of <limit> (inf where the file gives none).
    damping : float
        Viscous damping coefficient of <dynamics damping=...> (0 where none), in
        N m s/rad or N s/m.
    """

    name: str
    kind: str
    lower: float
    upper: float
    velocity: float
    effort: float
    damping: float

    @property
    def units(self):
        """(unit of the coordinate, unit of the effort)."""
        return MOVABLE[self.kind]


def read_urdf(path):
    """The movable joints of the URDF file at `path`, in the file's order, and its text
    with the defaults of the URDF specification written out.

    Parameters
    ----------
    path : pathlib.Path

    Returns
    -------
    joints : tuple of Joint
    text : str
        The file's XML with an identity ``<origin xyz="0 0 0" rpy="0 0 0"/>`` in every
        <joint> and <inertial> that has none and ``<axis xyz="1 0 0"/>`` in every movable
        joint without an axis, the specification's defaults.

    Raises
    ------
    MissingFileError
        No file at `path`.
    InputError
        Not a URDF (no <robot> root), a joint of a type dmoc cannot take (floating,
        planar: dmoc adds the base's pose itself), a zero axis or malformed numbers; the
        message names the file and the joint.
    """
    readable_file("path", path)
    try:
        root = ElementTree.parse(path).getroot()
    except ElementTree.ParseError as err:
        raise InputError(f"`path` must be a URDF file (XML); {str(path)!r} does not parse: {err}.") from None
    if root.tag != "robot":
        raise InputError(f"`path` must be a URDF file, its root element <robot>; {str(path)!r} "
                         f"has <{root.tag}>.")
    joints = []
    for element in root.iter("joint"):
        kind = element.get("type")
        if kind == FIXED:
            continue
        if kind not in MOVABLE:
            raise InputError(f"joint {element.get('name')!r} of {str(path)!r} is of type {kind!r}; "
                             f"dmoc takes joints of type {sorted(MOVABLE)} or 'fixed'. The "
                             f"file's root link is the base: fixed, or rolling on its wheels "
                             f"with `wheels=` (dmoc adds its planar pose x, y, theta), so "
                             f"remove a planar joint to a world link; for a floating base, "
                             f"remove the floating joint and read the file with "
                             f"dmoc.FloatingBaseRobot, which adds the base's pose.")
        joints.append(_joint(element, kind, path))
    if not joints:
        raise InputError(f"`path` must describe a robot with movable joints; {str(path)!r} has none.")
    _write_defaults(root)
    return tuple(joints), ElementTree.tostring(root, encoding="unicode")


def _write_defaults(root):
    """Add the elements the URDF specification lets a file omit, with their default values."""
    for element in (*root.iter("joint"), *root.iter("inertial")):
        if element.find("origin") is None:
            ElementTree.SubElement(element, "origin", xyz="0 0 0", rpy="0 0 0")
    for element in root.iter("joint"):
        if element.get("type") in MOVABLE and element.find("axis") is None:
            ElementTree.SubElement(element, "axis", xyz="1 0 0")


def _numbers(text, name, path):
    """The three numbers of an xyz attribute of joint `name`."""
    try:
        values = [float(x) for x in text.split()]
    except ValueError:
        values = []
    if len(values) != 3:
        raise InputError(f"joint {name!r} of {str(path)!r}: xyz={text!r} must be three numbers.")
    return values


def _joint(element, kind, path):
    """The Joint of the <joint> `element` of type `kind`."""
    name = element.get("name")
    limit, dynamics = element.find("limit"), element.find("dynamics")

    def number(node, key, default):
        text = None if node is None else node.get(key)
        if text is None:
            return default
        try:
            return float(text)
        except ValueError:
            raise InputError(f"joint {name!r} of {str(path)!r}: {key}={text!r} is not a number.") from None

    lower, upper = number(limit, "lower", -math.inf), number(limit, "upper", math.inf)
    if kind == "continuous" or (lower == 0 and upper == 0):   # URDF: no range given
        lower, upper = -math.inf, math.inf
    if not lower < upper:
        raise InputError(f"joint {name!r} of {str(path)!r}: its limits must satisfy lower < "
                         f"upper; got lower={lower}, upper={upper}.")
    axis = element.find("axis")
    if axis is not None and not any(_numbers(axis.get("xyz", "1 0 0"), name, path)):
        raise InputError(f"joint {name!r} of {str(path)!r}: its <axis xyz> must be a nonzero "
                         f"vector (the joint's direction); got {axis.get('xyz')!r}.")
    damping = number(dynamics, "damping", 0.0)
    if not damping >= 0:
        raise InputError(f"joint {name!r} of {str(path)!r}: damping must be >= 0; got {damping}.")
    return Joint(name, kind, lower, upper, number(limit, "velocity", math.inf),
                 number(limit, "effort", math.inf), damping)


def chosen_joints(movable, joints):
    """The Joints named in `joints` (all of `movable` when None), in that order."""
    if joints is None:
        return movable
    by_name = {j.name: j for j in movable}
    if isinstance(joints, str) or not hasattr(joints, "__iter__"):
        raise InputTypeError(f"`joints` must be a sequence of joint names; got "
                             f"{type(joints).__name__}.")
    chosen = tuple(joints)
    unknown = [s for s in chosen if s not in by_name]
    if unknown or not chosen or len(set(chosen)) < len(chosen):
        raise InputError(f"`joints` must be distinct names of movable joints of the file, "
                         f"among {list(by_name)}; got {list(chosen)}"
                         + (f" ({unknown} not among them)." if unknown else "."))
    return tuple(by_name[s] for s in chosen)


def joint_friction(friction, joints):
    """The friction coefficients, shape (n,): the file's damping when `friction` is None."""
    n = len(joints)
    if friction is None:
        return np.array([j.damping for j in joints])
    if np.ndim(friction) == 0:
        return np.full(n, checks.nonnegative_float("friction", friction))
    d = checks.vector("friction", friction, n)
    if (d < 0).any():
        raise InputError(f"`friction` must be >= 0 at every joint; got {d}.")
    return d
