"""A robot from its URDF file as a MechanicalSystem, for the mechanics stage, on a fixed
base or on wheels: L(q, v) = T(q, v) - V(q), the links' kinetic and gravitational energies
summed over the kinematic tree by the forward recursion of `link_recursion` (O(n) nodes for
n joints, so that the step's second derivatives of L stay O(n^2)), on the tree, joint frames
and inertias adam [1]_ parses from the file; the joint torques are the controls and viscous
joint friction a force; a wheeled base's rolling rows are constraint one-forms (27)
(`wheeled_base`).
"""

import functools

import casadi as ca
import numpy as np

from ..._util import checks
from ...errors import InputError
from ..system import MechanicalSystem
from .link_recursion import Link, energies, placement, rpy_rotation
from .spatial_hessian import second_variation
from .step_failure import step_failure_hint
from .urdf_file import chosen_joints, joint_friction, read_urdf
from .wheeled_base import (BASE_NAMES, BASE_UNITS, base_velocity, read_wheels, rolling_constraints,
                           rolling_rows, world_position)

EXTRA = "pip install 'dmoc[robots]'"


class RobotSystem(MechanicalSystem):
    """A robot read from a URDF file, as a MechanicalSystem: an arm on a fixed base (n
    joints, n torques) or, with `wheels`, a mobile robot whose base rolls on its wheels (n =
    3 + joints, the base's pose first; m rolling rows (27); a torque per joint).

    Parameters
    ----------
    path : str or os.PathLike
        The URDF file: `dmoc.mechanics.robots.example_urdf` gives the shipped ones.
    joints : sequence of str, optional
        The joints that move, in the order of q; the file's other movable joints are held at
        0. Default: every movable joint, in the file's order.
    wheels : sequence of str or mapping of str to float or None, optional
        The wheel joints (among `joints`): the file's root link becomes a base rolling on
        them on the horizontal plane, its pose (x, y, theta) the first three coordinates of
        q. Each wheel's axle and centre come from its joint's axis and origin, its radius
        from its link's <collision> (else <visual>) cylinder, or from the mapping's value
        (m) where not None (docs/robots.md, "A mobile manipulator"). Default: a fixed base.
    friction : float or array_like of shape (n,), optional
        Viscous joint friction coefficients d >= 0 (N m s/rad, N s/m); default the file's
        ``<dynamics damping=...>`` (0 where absent).
    gravity : float, optional
        Gravitational acceleration g along -z of the base's frame (default 9.81 m/s^2).

    Attributes
    ----------
    path : pathlib.Path
    joints : tuple of dmoc.mechanics.robots.urdf_file.Joint
        The moving joints with their limits and damping, in the order of q.
    n, n_u, m : int
        Sizes of q (the moving joints, after x, y, theta on wheels), of the torques (one
        per moving joint) and of the rolling rows (0 on a fixed base).
    names, control_names : tuple of str
        "x", "y", "theta" on wheels, then the joints' names; ``tau_<joint>``, the torques'
        (for plots and the CSV table).
    position_limits, effort_limits : tuple of ndarray, shapes (n,) and (n_u,)
        (lower, upper) positions and torques of the file, +-inf where it gives none (and
        for the base's pose): ready for `OptimalControlProblem`'s ``state_bounds`` and
        ``control_bounds``.
    velocity_limits : ndarray, shape (n,)
    friction : ndarray, shape (n_u,)
        The joints' friction coefficients.
    gravity : float
        g (m/s^2), along -z of the base's frame.
    links : tuple of dmoc.mechanics.robots.link_recursion.Link
        The kinematic tree, parents before children, the base first.
    wheels : tuple of dmoc.mechanics.robots.wheeled_base.Wheel
        The wheels read from the file, () on a fixed base.
    wheel_rows : tuple of str
        The rolling rows' names, in the order of the rows of A(q): "<joint> rolls", then
        "<joint> does not slip sideways" where independent.
    mass_matrix : casadi.Function
        ``M(q) = d^2T/dv^2`` (n, n), symmetric positive definite.
    potential : casadi.Function
        ``V(q)``, the gravitational energy g sum_i m_i z_i(q) (the base's mass included, a
        constant).

    Notes
    -----
    With D = diag(friction) and the torques u as controls:

        L(q, v) = 1/2 v^T M(q) v - V(q),      f(q, v, u) = u - D v,

    so that the Lagrange-d'Alembert equations are M(q) v' + C(q, v) v + dV/dq = u - D v,
    the rigid-body equations of motion (C(q, v) v the Coriolis and centrifugal terms). On
    wheels, f = (0, 0, 0, u - D v_joints) and the equations gain the constraint forces
    A(q)^T lam with A(q) v = 0, A(q) = B diag(R(theta)^T, 1, I) the wheels' rolling rows
    (`dmoc.mechanics.robots.wheeled_base.rolling_rows`); the base's velocity enters the
    recursion as w_0 = (0, 0, thetadot), v_0 = R(theta)^T (xdot, ydot, 0).
    L is not built from M(q): T = 1/2 v^T M(q) v is summed over the links from their
    velocities, each link's from its parent's (`dmoc.mechanics.robots.link_recursion`),
    which costs O(n) nodes where M(q) costs O(n^2) entries of O(n) each. adam parses the
    file (the tree, the joints' origins and axes, the links' inertias); the tests check
    M, dV/dq and the bias terms of L against Pinocchio's.

    References
    ----------
    .. [1] G. L'Erario et al., adam: Automatic Differentiation for rigid-body-dynamics
       AlgorithMs, https://github.com/ami-iit/adam.

    Examples
    --------
    >>> from dmoc.mechanics.robots import example_urdf
    >>> arm = RobotSystem(example_urdf("double_pendulum"))
    >>> (arm.n, arm.n_u, arm.names)
    (2, 2, ('shoulder', 'elbow'))
    >>> robot = RobotSystem(example_urdf("mobile_arm"), wheels=("left_wheel", "right_wheel"))
    >>> (robot.n, robot.m, robot.n_u, robot.names[:4])
    (8, 3, 5, ('x', 'y', 'theta', 'left_wheel'))
    """

    def __init__(self, path, joints=None, *, wheels=None, friction=None, gravity=9.81):
        text, g = read_model(self, path, joints, friction, gravity)
        self.gravity = g
        self.wheels = () if wheels is None else read_wheels(wheels, self.joints, self.links,
                                                            text, self.path)
        self.wheel_rows, constraints = (), None
        if self.wheels:
            B, self.wheel_rows = rolling_rows(self.wheels, len(self.joints))
            constraints = rolling_constraints(B)
        k, n_u = (3 if self.wheels else 0), len(self.joints)
        q, v = ca.SX.sym("q", k + n_u), ca.SX.sym("v", k + n_u)
        T, V = energies(self.links, q[k:], v[k:], g, base_velocity(q, v) if k else None)
        self.mass_matrix = ca.Function("M", [q], [ca.hessian(T, v)[0]], ["q"], ["M"])
        self.potential = ca.Function("V", [q], [V], ["q"], ["V"])
        self._set_limits(k)
        D = ca.DM(self.friction)
        super().__init__(ca.Function("L", [q, v], [T - V]), k + n_u, constraints=constraints,
                         force=lambda q, v, u: ca.vertcat(ca.SX.zeros(k), u - D * v[k:]), n_u=n_u,
                         names=BASE_NAMES[:k] + tuple(j.name for j in self.joints),
                         control_names=tuple(f"tau_{j.name}" for j in self.joints),
                         units={"t": "s",
                                "q": BASE_UNITS[:k] + tuple(j.units[0] for j in self.joints),
                                "u": tuple(j.units[1] for j in self.joints)})

    def _set_limits(self, k):
        """The limits of the file, the base's k coordinates unbounded."""
        free = np.full(k, np.inf)
        self.position_limits = (np.concatenate([-free, [j.lower for j in self.joints]]),
                                np.concatenate([free, [j.upper for j in self.joints]]))
        self.effort_limits = (-np.array([j.effort for j in self.joints]),
                              np.array([j.effort for j in self.joints]))
        self.velocity_limits = np.concatenate([free, [j.velocity for j in self.joints]])

    def link_position(self, name):
        """The position of a link's frame origin, a casadi.Function q -> (3,) in the world's
        frame (the fixed base's frame, or the plane's for a wheeled base).

        Parameters
        ----------
        name : str
            A link of the file.

        Returns
        -------
        casadi.Function
            ``link_position(q)``, q of shape (n,), named after the link.

        Examples
        --------
        >>> from dmoc.mechanics.robots import example_urdf
        >>> robot = RobotSystem(example_urdf("mobile_arm"), wheels=("left_wheel", "right_wheel"))
        >>> robot.link_position("tool")([1, 2, 0, 0, 0, 0, 0, 0])    # the arm upright
        DM([1.15, 2, 0.78])
        """
        names = [link.name for link in self.links]
        checks.choice("name", name, tuple(names))
        k = 3 if self.wheels else 0
        q = ca.SX.sym("q", self.n)
        _, p = placement(self.links, names.index(name), q[k:])
        return ca.Function(name, [q], [world_position(q, p) if k else p], ["q"], ["position"])

    def second_variation(self, q, v, a, b):
        """The second variation of L along the directions a and b, W[i, j] = (a_q d/dq_i +
        a_v d/dv_i)(b_q d/dq_j + b_v d/dv_j) L at (q, v), (n, n) SX, by the spatial
        formulas of `dmoc.mechanics.robots.spatial_hessian` (O(1) operations per entry;
        the step's Jacobian takes it, `dmoc.simulation.step_jacobian`); None on wheels,
        whose base's pose those formulas do not cover.

        Parameters
        ----------
        q, v : casadi.SX, shape (n, 1)
        a, b : pair of float or casadi.SX
            (a_q, a_v) and (b_q, b_v).

        Returns
        -------
        casadi.SX of shape (n, n), or None
        """
        return None if self.wheels else second_variation(self.links, q, v, self.gravity, a, b)

    @functools.cached_property
    def stiffness(self):
        """``K(q) = d^2V/dq^2`` (n, n), the stiffness of gravity, a casadi.Function built on
        first use (by `step_failure_hint`)."""
        q = ca.SX.sym("q", self.n)
        return ca.Function("K", [q], [ca.hessian(self.potential(q), q)[0]], ["q"], ["K"])

    def step_failure_hint(self, q, p, h):
        """What a failed step at the state (q, p) with step h suggests: the joint
        velocities, the fastest mode against h and the conditioning of M(q).

        Parameters
        ----------
        q, p : array_like, shape (n,)
            The last accepted configuration and momentum.
        h : float

        Returns
        -------
        str
        """
        return step_failure_hint(self, np.asarray(q, float), np.asarray(p, float), float(h))

    def __repr__(self):
        wheels = f", wheels={tuple(w.joint for w in self.wheels)}" if self.wheels else ""
        return f"RobotSystem({str(self.path)!r}{wheels}, n={self.n}, names={self.names})"


def read_model(robot, path, joints, friction, gravity):
    """Set `robot`'s path, joints, friction and links from the URDF file `path` (the
    `joints` chosen among its movable ones, `friction` per joint); return (the file's
    text, the checked `gravity`)."""
    robot.path = checks.file_path("path", path)
    movable, text = read_urdf(robot.path)
    robot.joints = chosen_joints(movable, joints)
    g = checks.finite_float("gravity", gravity)
    robot.friction = joint_friction(friction, robot.joints)
    robot.links = _tree(text, robot.joints)
    return text, g


def _tree(text, joints):
    """The links of the URDF `text` as adam parses them (its tree, the joints' origins and
    axes, the links' inertias), with the `joints` moving and the file's others held at 0."""
    try:
        from adam.casadi import casadi_like
        from adam.model import Model, build_model_factory
    except ImportError as err:
        raise ModuleNotFoundError(f"RobotSystem reads URDF files with adam-robotics, which is "
                                  f"not installed ({err}); install the extra: {EXTRA}.",
                                  name="adam") from err
    names = [j.name for j in joints]
    try:
        model = Model.build(build_model_factory(text, casadi_like.SpatialMath()), names)
    except Exception as err:       # adam's errors on a model it cannot take, reported as ours
        raise InputError(f"`path`: adam could not build the rigid-body model of the file with "
                         f"the joints {names}: {type(err).__name__}: {err}") from err
    order = {name: i for i, name in enumerate(model.tree.ordered_nodes_list)}
    return tuple(_link(node, order) for node in model.tree)


def _link(node, order):
    """The `Link` of adam's tree node `node`; `order` maps link names to their index."""
    link, joint, parent = node.get_elements()
    inertial = link.inertial
    turn = rpy_rotation(_numbers(inertial.origin.rpy))
    inertia = turn @ _numbers(inertial.inertia.matrix) @ turn.T
    mass, center = float(_numbers(inertial.mass)), _numbers(inertial.origin.xyz)
    if joint is None:
        return Link(link.name, None, "base", None, np.zeros(3), np.eye(3), np.zeros(3), mass, center, inertia)
    axis = np.zeros(3)
    if joint.idx is not None:
        axis = _numbers(joint.axis)
        axis = axis / np.linalg.norm(axis)
    return Link(link.name, order[parent.name], joint.type if joint.idx is not None else "fixed", joint.idx,
                _numbers(joint.origin.xyz), rpy_rotation(_numbers(joint.origin.rpy)), axis,
                mass, center, inertia)


def _numbers(value):
    """The numbers of one of adam's constant CasADi arrays: shape (3,) for a vector, (3, 3)
    for a matrix, () for a scalar."""
    return np.squeeze(np.array(ca.evalf(ca.SX(value.array)), float))
