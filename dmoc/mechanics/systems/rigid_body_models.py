"""Rigid bodies on SO(3) x R^n_x (`dmoc.RigidBody`): the free rigid body (Euler's equations
Pi' = Pi x Omega, R' = R Omega^), alone or in space on SE(3) with its centre of mass as the
vector coordinates, the heavy top (a body in gravity, pivoted at a point other than its
centre of mass), a spacecraft turned by three body torques (and moved by body-fixed
thrusters when it has a mass), the Chaplygin sphere (a ball with an anisotropic inertia
rolling without slipping on a plane, its contact point (x, y) the vector coordinates), and
a quadrotor (a thrust along its body axis and three body torques, its centre of mass the
vector coordinates). Their oracles are the conserved quantities (energy; the spatial
angular momentum R Pi, or its vertical component for the heavy top; the linear and
angular momenta of the body in space; the rolling constraints) and the reduced equations
integrated by DOP853 in the tests.
"""

import casadi as ca

from ..._util import checks
from ..rigid_body import RigidBody


def free_rigid_body(inertia=(1.0, 2.0, 3.0), mass=None):
    """The free rigid body: L = 1/2 Omega^T J Omega, no potential, no torque; with a `mass`,
    the free body in space on SE(3) = SO(3) x| R^3, x its centre of mass (spatial frame):

        L = 1/2 Omega^T J Omega + 1/2 m |x'|^2,

    the product Lagrangian on SO(3) x R^3 (docs/theory.md, "SE(3): a free body in space").
    Its momentum maps are the linear momentum m x' and the angular momentum about the
    origin x x m x' + R J Omega, both conserved.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Principal moments or the inertia tensor J (body frame, about the centre of mass).
    mass : float, optional
        m > 0. None: the body with a fixed point, on SO(3).

    Returns
    -------
    RigidBody
        n_x = 0, or n_x = 3 (x) with a mass.
    """
    if mass is None:
        return RigidBody(inertia, name="free rigid body")
    m = checks.positive_float("mass", mass)
    return RigidBody(inertia, coordinates=(m, m, m), name="free rigid body in space")


def heavy_top(inertia=(1.0, 1.0, 0.4), mass=1.0, centre=(0.0, 0.0, 0.5), gravity=9.81):
    """The heavy top: a body pivoted at a fixed point, its centre of mass at `centre` in the
    body frame, in gravity along -e3: U(R) = m g e3 . R rho. Rotations about the spatial
    vertical e3 are a symmetry, so e3 . R Pi (the vertical spatial angular momentum) is
    conserved.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Inertia about the pivot (body frame).
    mass, gravity : float
        m > 0 and g >= 0.
    centre : array_like, shape (3,)
        rho, the centre of mass from the pivot, body frame.

    Returns
    -------
    RigidBody
    """
    m = checks.positive_float("mass", mass)
    g = checks.nonnegative_float("gravity", gravity)
    rho = ca.DM(checks.array("centre", centre, (3,)))
    return RigidBody(inertia, potential=lambda R: m * g * ca.mtimes(R[2, :], rho),
                     name="heavy top")


def spacecraft(inertia=(1.0, 1.0, 1.0), mass=None):
    """A spacecraft turned by three body torques, the controls: L = 1/2 Omega^T J Omega,
    tau = u (n_u = 3, body frame). With equal principal moments I, the rest-to-rest slew
    through an angle theta in time T that minimizes the integral of |u|^2 is the eigenaxis
    rotation with theta(t) cubic, of cost 12 I^2 theta^2 / T^3.

    With a `mass`, the spacecraft moves in space as well (the free body on SE(3) of
    `free_rigid_body`, x its centre of mass) under body-fixed thrusters: the controls are
    u = (tau, F) (n_u = 6), the body torque tau and the force F, both in the body frame,
    and the generalized force is (tau, R F) (the force on x in the spatial frame). Its
    reduced equations are J Omega' = J Omega x Omega + tau, R' = R Omega^, m x'' = R F.
    Since |R F| = |F|, the rest-to-rest move by d and turn by theta (equal moments I)
    minimizing the integral of |u|^2 splits into the eigenaxis slew and the straight move
    with x(t) cubic: its cost is 12 (I^2 theta^2 + m^2 |d|^2) / T^3.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        J about the centre of mass (body frame).
    mass : float, optional
        m > 0. None: the spacecraft turns about its fixed centre, on SO(3).

    Returns
    -------
    RigidBody
        n_x = 0, n_u = 3; or n_x = 3 (x), n_u = 6 with a mass.
    """
    if mass is None:
        return RigidBody(inertia, torque=lambda R, omega, u: u, n_u=3, name="spacecraft")
    m = checks.positive_float("mass", mass)

    def torque_and_thrust(R, omega, x, v, u):
        return ca.vertcat(u[:3], ca.mtimes(R, u[3:]))

    return RigidBody(inertia, coordinates=(m, m, m), torque=torque_and_thrust, n_u=6,
                     name="spacecraft in space")


def chaplygin_sphere(inertia=(1.0, 2.0, 3.0), mass=1.0, radius=1.0, torques=False):
    """The Chaplygin sphere: a ball of radius r and mass m whose centre of mass is its
    geometric centre, with the body-frame inertia J about the centre, rolling without
    slipping on the horizontal plane. Configuration (R, x) in SO(3) x R^2, x the position
    (x, y) of the centre (and of the contact point below it);

        L = 1/2 Omega^T J Omega + 1/2 m |x'|^2,

    the rolling constraints (the material point at the contact, c - r e3, at rest):
    x' = r P (omega x e3), omega = R Omega the spatial angular velocity and P the first
    two rows, i.e. A = [r P e3^ R, I_2] on (Omega, x'). Gravity and the normal force do no
    work (the centre stays at height r) and are left out. Energy and the contact angular
    momentum K = R J Omega + m r^2 (omega - (e3 . omega) e3) (spatial) are conserved.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        J about the centre (body frame).
    mass, radius : float
        m > 0 and r > 0.
    torques : bool
        With True, three body torques u (n_u = 3, body frame) are the controls.

    Returns
    -------
    RigidBody
        n_x = 2, m = 2.
    """
    m = checks.positive_float("mass", mass)
    r = checks.positive_float("radius", radius)
    torques = checks.boolean("torques", torques)
    e3_hat = ca.DM([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])    # the first two rows of e3^

    def rolling(R, x):
        return ca.horzcat(r * ca.mtimes(e3_hat, R), ca.DM.eye(2))

    def torque(R, omega, x, v, u):
        return ca.vertcat(u, ca.SX.zeros(2))

    return RigidBody(inertia, coordinates=(m, m), constraints=rolling,
                     torque=torque if torques else None, n_u=3 if torques else 0,
                     name="Chaplygin sphere")


def quadrotor(mass=1.0, inertia=(0.02, 0.02, 0.04), gravity=9.81):
    """A quadrotor: a rigid body with rotation R and centre of mass x in R^3, driven by a
    thrust f along its body axis R e3 and three body torques, in gravity along -e3:

        L = 1/2 Omega^T J Omega + 1/2 m |x'|^2 - m g x_3,

    controls u = (f, tau_1, tau_2, tau_3) (n_u = 4), the generalized force (tau, f R e3):
    the body torque on R and the thrust on x. Its reduced equations are
    m x'' = f R e3 - m g e3, R' = R Omega^, J Omega' = J Omega x Omega + tau (Lee, Leok &
    McClamroch, "Geometric tracking control of a quadrotor UAV on SE(3)", CDC 2010). It
    hovers at rest, at any position, with R = I, f = m g and tau = 0.

    Parameters
    ----------
    mass : float
        m > 0.
    inertia : array_like, shape (3,) or (3, 3)
        J about the centre of mass (body frame).
    gravity : float
        g >= 0.

    Returns
    -------
    RigidBody
        n_x = 3, m = 0, n_u = 4.
    """
    m = checks.positive_float("mass", mass)
    g = checks.nonnegative_float("gravity", gravity)

    def thrust_and_torques(R, omega, x, v, u):
        return ca.vertcat(u[1:], u[0] * R[:, 2])

    return RigidBody(inertia, coordinates=(m, m, m), potential=lambda R, x: m * g * x[2],
                     torque=thrust_and_torques, n_u=4, name="quadrotor")
