"""The spherical pendulum in Cartesian coordinates, a first-stage example system with a
holonomic constraint: a bob on a massless rod, q = (x, y, z) with z up, kept on the sphere
g(q) = abs(q)^2 - l^2 = 0, with a horizontal control force. Its energy and its vertical
angular momentum are the invariants the discrete principles (46)/(47) keep
(docs/holonomic.md).
"""

import casadi as ca

from ..._util import checks
from ..bodies import Body
from ..system import MechanicalSystem


def spherical_pendulum(mass=1.0, length=1.0, gravity=9.81):
    """Spherical pendulum as a MechanicalSystem (n=3, m=1 holonomic, n_u=2).

    Parameters
    ----------
    mass : float
        Mass m > 0 of the bob.
    length : float
        Length l > 0 of the rod.
    gravity : float
        Gravitational acceleration g, pulling towards negative z.

    Returns
    -------
    MechanicalSystem
        q = (x, y, z), shape (3,), the bob's position relative to the pivot; controls
        u = (u0, u1), shape (2,), a horizontal force on the bob, named "force_x" and
        "force_y". Its `units` (for plots): m; N; time in s. Its body: the "bob", a point
        at (x, y) seen from above.

    Notes
    -----
    With the rod's constraint as a holonomic constraint (docs/holonomic.md):

        L(q, v) = m/2 abs(v)^2 - m g z,
        g(q) = x^2 + y^2 + z^2 - l^2          (so dg/dq = 2 q^T),
        f(q, v, u) = (u0, u1, 0).

    The rod's tension is the multiplier: m q'' = -m g e_z + 2 q lam + f. Without control
    the energy m/2 abs(v)^2 + m g z and the vertical angular momentum m (x y' - y x') are
    conserved; the discrete ones of the scheme, x p_y - y p_x from the discrete momenta, are
    conserved exactly (discrete Noether: L_d and g are invariant under rotations about the
    z axis). A conical motion at height z = -l cos(theta) circles at the rate Omega with
    Omega^2 = g / (l cos(theta)).

    Examples
    --------
    >>> s = spherical_pendulum(length=2.0)
    >>> (s.n, s.m, s.n_holonomic, s.n_u, s.names)
    (3, 1, 1, 2, ('x', 'y', 'z'))
    >>> float(s.holonomic([0.0, 0.0, -2.0]))
    0.0
    """
    m = checks.positive_float("mass", mass)
    l = checks.positive_float("length", length)
    g = checks.finite_float("gravity", gravity)

    def lagrangian(q, v):
        return m / 2 * ca.dot(v, v) - m * g * q[2]

    def force(q, v, u):
        return ca.vertcat(u[0], u[1], 0)

    return MechanicalSystem(lagrangian, 3, holonomic=lambda q: ca.dot(q, q) - l ** 2,
                            force=force, n_u=2, names=("x", "y", "z"),
                            control_names=("force_x", "force_y"),
                            bodies=(Body("bob", lambda q: q[None, :2]),),
                            units={"t": "s", "q": ("m", "m", "m"), "u": ("N", "N")})
