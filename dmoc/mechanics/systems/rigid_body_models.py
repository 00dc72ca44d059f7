"""Rigid bodies with a fixed point, on SO(3) (`dmoc.RigidBody`): the free rigid body (Euler's
equations Pi' = Pi x Omega, R' = R Omega^), the heavy top (a body in gravity, pivoted at a
point other than its centre of mass) and a spacecraft turned by three body torques. Their
oracles are the conserved quantities (energy; the spatial angular momentum R Pi, or its
vertical component for the heavy top) and the reduced equations integrated by DOP853 in the
tests.
"""

import casadi as ca

from ..._util import checks
from ..rigid_body import RigidBody


def free_rigid_body(inertia=(1.0, 2.0, 3.0)):
    """The free rigid body: L = 1/2 Omega^T J Omega, no potential, no torque.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Principal moments or the inertia tensor J (body frame).

    Returns
    -------
    RigidBody
    """
    return RigidBody(inertia, name="free rigid body")


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


def spacecraft(inertia=(1.0, 1.0, 1.0)):
    """A spacecraft turned by three body torques, the controls: L = 1/2 Omega^T J Omega,
    tau = u (n_u = 3, body frame). With equal principal moments I, the rest-to-rest slew
    through an angle theta in time T that minimizes the integral of |u|^2 is the eigenaxis
    rotation with theta(t) cubic, of cost 12 I^2 theta^2 / T^3.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)

    Returns
    -------
    RigidBody
    """
    return RigidBody(inertia, torque=lambda R, omega, u: u, n_u=3, name="spacecraft")
