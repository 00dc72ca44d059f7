"""The Lagrangian of a robot by the forward recursion over its kinematic tree, from a base at
rest or moving in the horizontal plane, and its links' placements, for the mechanics stage:
each link's angular velocity and the velocity of its origin in its own frame from its
parent's, its centre of mass's velocity and height, and from them the
kinetic energy T = sum_i 1/2 m_i |v_ci|^2 + 1/2 w_i^T I_i w_i and the gravitational energy
V = g sum_i m_i z_ci. The graph of L has O(n) nodes for n joints (the mass matrix M(q) has
n^2 entries of O(n) nodes each), so the step's second derivatives of L stay O(n^2).
The tree, the joints' origins and axes and the links' inertias are those adam parsed
(`dmoc.mechanics.robots.robot_system`).
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

REVOLUTE = ("revolute", "continuous")
PRISMATIC = "prismatic"
ROUND_OFF = 1e-15    # entries of a constant rotation below this are rounding errors of zeros


@dataclass(frozen=True)
class Link:
    """One rigid link of the tree, with the joint that carries it from its parent.

    Attributes
    ----------
    name : str
        The link's name in the file.
    parent : int or None
        Index of the parent link in the tree's order (parents before children); None for
        the base.
    kind : str
        The joint's type: "revolute", "continuous", "prismatic" or "fixed" ("fixed" also
        for a movable joint held at 0); "base" for the base.
    index : int or None
        The joint's coordinate in q (None when it does not move: "fixed" and "base").
    origin : ndarray, shape (3,)
        The joint frame's origin in the parent's frame (<origin xyz>).
    rotation : ndarray, shape (3, 3)
        The joint frame's orientation in the parent's frame (<origin rpy>).
    axis : ndarray, shape (3,)
        The joint's unit axis in the joint frame (<axis xyz>, normalized; unused when it
        does not move).
    mass : float
    center : ndarray, shape (3,)
        The centre of mass in the link's frame.
    inertia : ndarray, shape (3, 3)
        The rotational inertia about the centre of mass, in the link's frame (the
        <inertial>'s inertia turned by its rpy).
    """

    name: str
    parent: object
    kind: str
    index: object
    origin: np.ndarray
    rotation: np.ndarray
    axis: np.ndarray
    mass: float
    center: np.ndarray
    inertia: np.ndarray


def rpy_rotation(rpy):
    """R = Rz(yaw) Ry(pitch) Rx(roll), the URDF convention (fixed axes x, y, z), (3, 3);
    entries within ROUND_OFF of 0 are 0 (cos(pi/2) in doubles is 6e-17), so that a frame
    turned by a multiple of pi/2 multiplies no more than an unturned one."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    R = np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                  [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                  [-sp, cp * sr, cp * cr]])
    return np.where(np.abs(R) < ROUND_OFF, 0.0, R)


def axis_rotation(axis, angle):
    """Rot(a, angle) = a a^T + cos (I - a a^T) + sin K about the unit axis a, K its
    cross-product matrix (Rodrigues' formula), (3, 3) SX; for a coordinate axis the entries
    are 1, 0, +-cos or +-sin, with no arithmetic on constants."""
    a = np.asarray(axis, float)
    along = np.outer(a, a)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return ca.SX(along) + ca.cos(angle) * ca.SX(np.eye(3) - along) + ca.sin(angle) * ca.SX(K)


def energies(links, q, v, gravity, base=None, height=None):
    """The kinetic and gravitational energies of the tree `links` at (q, v).

    Parameters
    ----------
    links : sequence of Link
        Parents before children, the base first.
    q, v : casadi.SX, shape (n, 1)
        Joint positions and velocities, in the order of the links' ``index``.
    gravity : float
        g, along -z of the base's frame (of the world's with `height`).
    base : pair of casadi.SX of shape (3, 1), optional
        (w_0, v_0), the base's angular velocity and the velocity of its origin, in its own
        frame, for a base moving in the horizontal plane (its z axis stays vertical, so
        heights are still measured along its z) or floating; default at rest.
    height : pair of casadi.SX of shapes (1, 3) and (1, 1), optional
        (z_row_0, z_0): the third row of the base's orientation in the world's frame and the
        height of its origin, for a floating base; default (e_z^T, 0), heights measured
        along the base's z.

    Returns
    -------
    T, V : casadi.SX
        T(q, v) = sum_i 1/2 m_i |v_ci|^2 + 1/2 w_i^T I_i w_i and V(q) = g sum_i m_i z_ci,
        w_i the link's angular velocity and v_ci its centre of mass's velocity, both in the
        link's frame, z_ci the height of its centre of mass (in the base's frame, or the
        world's with `height`).

    Notes
    -----
    The recursion from the parent p to the link i through a joint with origin o, rotation
    R_o, axis a and coordinate (q_k, v_k): the link's orientation relative to its parent is
    R = R_o Rot(a, q_k) (revolute) or R_o (prismatic, whose origin moves to o + R_o a q_k),
    and, with every vector in its own link's frame,

        w_i = R^T w_p + a v_k                        (revolute)
        v_i = R^T (v_p + w_p x o_i) + a v_k          (the a v_k term prismatic only)
        v_ci = v_i + w_i x c_i,

    o_i the (moving) origin of link i in its parent's frame; the height needs only the third
    row e_z^T R_i of the link's orientation in the base's frame, z_row_i = z_row_p R.
    """
    frames = []        # per link: (w, v, z_row, z), w and v in the link's frame
    T, V = ca.SX(0), ca.SX(0)
    for link in links:
        if link.parent is None:
            w0, v0 = base if base is not None else (ca.SX.zeros(3), ca.SX.zeros(3))
            z_row0, z0 = height if height is not None else (ca.SX(np.array([[0.0, 0.0, 1.0]])), ca.SX(0))
            frame = (w0, v0, z_row0, z0)
        else:
            frame = _child_frame(link, frames[link.parent], q, v)
        frames.append(frame)
        if link.mass > 0:
            w, vel, z_row, z = frame
            c = ca.SX(link.center)
            v_c = vel + ca.cross(w, c)
            T += 0.5 * link.mass * ca.dot(v_c, v_c) + 0.5 * ca.bilin(ca.SX(link.inertia), w, w)
            V += gravity * link.mass * (z + ca.mtimes(z_row, c))
    return T, V


def joint_transform(link, q):
    """(R, o): the orientation (3, 3) and origin (3, 1) of `link`'s frame in its parent's
    frame at the joint positions q, SX: R = R_o Rot(a, q_k) and o for a revolute joint,
    R = R_o and o + R_o a q_k for a prismatic one, (R_o, o) for a fixed one."""
    R, o = ca.SX(link.rotation), ca.SX(link.origin)
    if link.kind in REVOLUTE:
        R = ca.mtimes(R, axis_rotation(link.axis, q[link.index]))
    elif link.kind == PRISMATIC:
        o = o + ca.mtimes(R, ca.SX(link.axis)) * q[link.index]
    return R, o


def placement(links, i, q):
    """(R, p): the orientation (3, 3) and origin (3, 1) of link `i`'s frame in the base's
    frame at the joint positions q, SX, composed down the chain from the base."""
    link = links[i]
    if link.parent is None:
        return ca.SX.eye(3), ca.SX.zeros(3)
    R_p, p_p = placement(links, link.parent, q)
    R, o = joint_transform(link, q)
    return ca.mtimes(R_p, R), p_p + ca.mtimes(R_p, o)


def _child_frame(link, parent, q, v):
    """(w, v, z_row, z) of `link` from those of its `parent` (the recursion of `energies`)."""
    w_p, v_p, z_row_p, z_p = parent
    a = ca.SX(link.axis)
    R, o = joint_transform(link, q)
    w = ca.mtimes(R.T, w_p)
    vel = ca.mtimes(R.T, v_p + ca.cross(w_p, o))
    if link.kind in REVOLUTE:
        w = w + a * v[link.index]
    elif link.kind == PRISMATIC:
        vel = vel + a * v[link.index]
    return w, vel, ca.mtimes(z_row_p, R), z_p + ca.mtimes(z_row_p, o)
