"""A robot from its URDF file on a floating base, for the mechanics stage: the file's root
link is a free body whose orientation R is carried as a group element of SO(3) and whose
position p is a vector coordinate, so that the robot lives on SO(3) x R^(3 + n_s), n_s
moving joints s; its Lagrangian L = 1/2 nu^T M(s) nu - V(R, p, s) with the body-fixed
velocity nu = (R^T p', Omega, s') summed over the links by the forward recursion of
`link_recursion`, the joint torques its controls (the base unactuated). Its discretization is
`dmoc.discrete.GroupDiscretization`'s general midpoint form (docs/robots.md, "A floating
base").
"""

import casadi as ca
import numpy as np

from ..rotations import matrix_of
from ..system import _fingerprint
from .link_recursion import energies, placement
from .robot_system import read_model
from .step_failure import explained

# the names of the step velocity's base entries: the body angular velocity Omega, then p'
BASE_VELOCITY = ("Omega_1", "Omega_2", "Omega_3", "x", "y", "z")


class FloatingBaseRobot:
    """A robot read from a URDF file whose root link floats: a satellite carrying an arm,
    a humanoid or a legged robot in flight, on SO(3) x R^n_x, n_x = 3 + n_s.

    Parameters
    ----------
    path : str or os.PathLike
        The URDF file (`dmoc.mechanics.robots.example_urdf("space_arm")` ships one); its
        root link is the base, with no joint to a world link (dmoc adds the base's pose, as
        Pinocchio's free-flyer root joint does).
    joints : sequence of str, optional
        The joints that move, in the order of s; the file's other movable joints are held
        at 0. Default: every movable joint, in the file's order.
    friction : float or array_like of shape (n_s,), optional
        Viscous joint friction coefficients d >= 0; default the file's ``<dynamics
        damping=...>`` (0 where absent).
    gravity : float, optional
        Gravitational acceleration g along -z of the world's frame (default 9.81 m/s^2;
        0 for a robot in orbit).

    Attributes
    ----------
    path : pathlib.Path
    joints : tuple of dmoc.mechanics.robots.urdf_file.Joint
        The moving joints, in the order of s.
    links : tuple of dmoc.mechanics.robots.link_recursion.Link
        The kinematic tree, parents before children, the base first.
    n_x, n, m, n_u : int
        3 + n_s (the base's position p, then the joints s), n = 3 + n_x (the velocity
        (Omega, p', s')), 0 constraint rows, n_s controls (one torque per joint).
    names, control_names : tuple of str
        The joints' names; ``tau_<joint>``, the torques'.
    position_limits, effort_limits : tuple of ndarray, shape (n_s,)
        (lower, upper) joint positions and torques of the file, +-inf where it gives none.
    friction : ndarray, shape (n_s,)
    mass : float
        The robot's total mass (kg).
    mass_matrix : casadi.Function
        ``M(s) -> M``, shape (6 + n_s, 6 + n_s): the mass matrix of the body-fixed velocity
        nu = (R^T p', Omega, s'), independent of the base's pose (Pinocchio's free-flyer
        convention: the base's linear velocity in its own frame first).
    generalized_mass : casadi.Function
        ``M(q) -> M``, shape (n, n): the mass matrix of the group step's velocity
        (Omega, p', s') at q = (the rows of R, p, s), P^T M(s) P with P (Omega, p', s') =
        (R^T p', Omega, s').
    kinetic_energy : casadi.Function
        ``T(R, x, omega, v) -> T``: 1/2 nu^T M(s) nu, x = (p, s), v = (p', s'), omega the
        base's body angular velocity Omega.
    potential : casadi.Function
        ``U(R, x) -> U``: g sum_i m_i z_i, the heights z_i of the links' centres of mass in
        the world's frame.
    torque : casadi.Function
        ``tau(R, omega, x, v, u) -> tau``, shape (n,): (0, 0, u - D s'), no torque or force
        on the base.
    constraint_matrix : casadi.Function
        ``A(q) -> A``, shape (0, n).
    center_of_mass : casadi.Function
        ``c(q) -> c``, shape (3,): the robot's centre of mass in the world's frame.
    energy : casadi.Function
        ``energy(q, p) -> E``: 1/2 p^T M(q)^{-1} p + U of q (9 + n_x,) and the momentum p
        = M(q) (Omega, p', s') (n,).
    momentum_map, momentum_rate : casadi.Function, ndarray
        ``J(q, p) -> J``, linear in p, and dJ/dt: the momenta that the discrete flow changes
        at a constant rate whatever the controls (Notes), exactly, J_k = J_0 + k h
        momentum_rate. Shape (6,) without gravity (the total linear momentum p_p, then the
        total angular momentum about the world's origin R Pi + p x p_p, all kept), shape
        (4,) with it (p_p, whose z changes at the rate -m g, and the angular momentum's z).
        A DMOC problem states the goal's momentum without them
        (`dmoc.optimal_control.statement.group_boundary.end_rows`).
    key : str
        Identifies the robot's data (the discretization, the step residual and the compiled
        steps are shared between equal robots).

    Notes
    -----
    With nu = (v_B, Omega, s'), v_B = R^T p' the base's velocity in its own frame, each
    link's angular velocity and the velocity of its centre of mass follow from the base's
    by the recursion of `dmoc.mechanics.robots.link_recursion.energies`, which starts from
    (w_0, v_0) = (Omega, R^T p') and from the base's height p_z with the third row of R:

        L(R, p, s, Omega, p', s') = 1/2 nu^T M(s) nu - g sum_i m_i (p + R r_i(s))_z,

    r_i(s) the centre of mass of link i in the base's frame. Without gravity L is invariant
    under translations p -> p + c and rotations (R, p) -> (Q R, Q p): the momentum maps
    are the total linear momentum p_p and the total angular momentum about the world's
    origin R Pi + p x p_p (Pi the body angular momentum conjugate to Omega), which the
    discrete flow keeps exactly (discrete Noether); with gravity only under horizontal
    translations and rotations about the vertical, which keep p_p's x and y and the
    angular momentum's z, while the weight changes p_p's z by -m g h per step
    (`momentum_map`). The equations of motion are
    M(s) nu' + C(s, nu) nu + G(R, s) = (0, 0, u - D s'); the tests compare M and G with
    Pinocchio's on a free-flyer root joint.

    Examples
    --------
    >>> from dmoc.mechanics.robots import example_urdf
    >>> robot = FloatingBaseRobot(example_urdf("space_arm"), gravity=0.0)
    >>> (robot.n_x, robot.n, robot.n_u, robot.names)
    (5, 8, 2, ('shoulder', 'elbow'))
    """

    m = 0

    def __init__(self, path, joints=None, *, friction=None, gravity=9.81):
        _, g = read_model(self, path, joints, friction, gravity)
        n_s = len(self.joints)
        self.n_x, self.n, self.n_u = 3 + n_s, 6 + n_s, n_s
        self.names = tuple(j.name for j in self.joints)
        self.control_names = tuple(f"tau_{name}" for name in self.names)
        self.position_limits = (np.array([j.lower for j in self.joints]),
                                np.array([j.upper for j in self.joints]))
        self.effort_limits = (-np.array([j.effort for j in self.joints]),
                              np.array([j.effort for j in self.joints]))
        self.mass = float(sum(link.mass for link in self.links))
        self._build(g)

    def _build(self, g):
        """The named Functions of the Attributes, from one pass of the link recursion."""
        R, x, omega, v = (ca.SX.sym("R", 3, 3), ca.SX.sym("x", self.n_x), ca.SX.sym("omega", 3),
                          ca.SX.sym("v", self.n_x))
        u, D = ca.SX.sym("u", self.n_u), ca.DM(self.friction)
        T, V = energies(self.links, x[3:], v[3:], g, base=(omega, ca.mtimes(R.T, v[:3])),
                        height=(R[2, :], x[2]))
        self.kinetic_energy = ca.Function("T", [R, x, omega, v], [T], ["R", "x", "omega", "v"], ["T"])
        self.potential = ca.Function("U", [R, x], [V], ["R", "x"], ["U"])
        self.torque = ca.Function("tau", [R, omega, x, v, u],
                                  [ca.vertcat(ca.SX.zeros(6), u - D * v[3:])],
                                  ["R", "omega", "x", "v", "u"], ["tau"])
        q, p, s, nu = (ca.SX.sym("q", 9 + self.n_x), ca.SX.sym("p", self.n),
                       ca.SX.sym("s", self.n_x - 3), ca.SX.sym("nu", self.n))
        self.constraint_matrix = ca.Function("A", [q], [ca.SX(0, self.n)], ["q"], ["A"])
        on_q = (matrix_of(q[:9]), q[9:])
        velocity = ca.vertcat(omega, v)
        M = ca.hessian(self.kinetic_energy(*on_q, omega, v), velocity)[0]
        self.generalized_mass = ca.Function("M", [q], [M], ["q"], ["M"])
        body = ca.vertcat(ca.SX.zeros(3), s)        # at R = I, p = 0: nu = (p', Omega, s')
        T_body = self.kinetic_energy(ca.SX.eye(3), body, nu[3:6], ca.vertcat(nu[:3], nu[6:]))
        self.mass_matrix = ca.Function("M_body", [s], [ca.hessian(T_body, nu)[0]], ["s"], ["M"])
        self.center_of_mass = ca.Function("c", [q], [self._center(*on_q)], ["q"], ["c"])
        angular = ca.mtimes(on_q[0], p[:3]) + ca.cross(q[9:12], p[3:6])
        kept = ca.vertcat(p[3:6], angular) if g == 0 else ca.vertcat(p[3:6], angular[2])
        self.momentum_map = ca.Function("J", [q, p], [kept], ["q", "p"], ["J"])
        self.momentum_rate = np.zeros(6) if g == 0 else np.array([0.0, 0.0, -self.mass * g, 0.0])
        kinetic = 0.5 * ca.dot(p, ca.solve(M, p))
        self.energy = ca.Function("energy", [q, p], [kinetic + self.potential(*on_q)], ["q", "p"], ["E"])
        self.key = _fingerprint(self.kinetic_energy, self.potential, self.torque, self.energy)

    def _center(self, R, x):
        """p + R sum_i m_i r_i(s) / m, shape (3, 1): the centre of mass in the world's frame."""
        moment = ca.SX.zeros(3)
        for i, link in enumerate(self.links):
            if link.mass > 0:
                R_i, o_i = placement(self.links, i, x[3:])
                moment += link.mass * (o_i + ca.mtimes(R_i, ca.SX(link.center)))
        return x[:3] + ca.mtimes(R, moment) / self.mass

    def step_failure_hint(self, q, p, h):
        """What a failed step at the state (q, p) with step h suggests: the base's and the
        joints' velocities (Omega, p', s') = M(q)^-1 p, the fastest turning among them
        against h, and the conditioning of M(q) (`generalized_mass`);
        no gravity mode (the robot falls as a whole in a uniform field).

        Parameters
        ----------
        q : array_like, shape (9 + n_x,)
            The last accepted configuration: the rows of R, then x = (p, s).
        p : array_like, shape (n,)
            Its momentum (Pi, p_x).
        h : float

        Returns
        -------
        str
        """
        M = np.array(self.generalized_mass(np.asarray(q, float)))
        units = ("rad",) * 3 + ("m",) * 3 + tuple(j.units[0] for j in self.joints)
        return explained(M, np.asarray(p, float), float(h), BASE_VELOCITY + self.names, units)

    def __repr__(self):
        return f"FloatingBaseRobot({str(self.path)!r}, n_x={self.n_x}, names={self.names})"
