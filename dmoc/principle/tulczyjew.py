"""The discrete Tulczyjew triple in coordinates (Section 3, eqs. (14)-(16)): the maps
kappa_d, Omega_d+^flat and Omega_d-^flat between T*Q x T*Q and T*(Q x Q), T*(Q x Q*),
T*(Q* x Q). Coordinates: z = (q0, p0), z+ = (q1, p1); a point of T*(Q x Q) is
(q0, q1, a0, a1), of T*(Q x Q*) is (q, p, a_q, a_p), of T*(Q* x Q) is (p, q, a_p, a_q).
"""


def kappa(z, z_plus):
    """kappa_d(z, z+) = (q0, q1, -p0, p1) in T*(Q x Q), eq. (14)."""
    (q0, p0), (q1, p1) = z, z_plus
    return (q0, q1, -p0, p1)


def omega_flat_plus(z, z_plus):
    """Omega_d+^flat(z, z+) = (q0, p1, p0, q1) in T*(Q x Q*), eq. (15)."""
    (q0, p0), (q1, p1) = z, z_plus
    return (q0, p1, p0, q1)


def omega_flat_minus(z, z_plus):
    """Omega_d-^flat(z, z+) = (p0, q1, -q0, -p1) in T*(Q* x Q), eq. (16)."""
    (q0, p0), (q1, p1) = z, z_plus
    return (p0, q1, -q0, -p1)


def kappa_inverse(point):
    """kappa_d^{-1}(q0, q1, a0, a1) = ((q0, -a0), (q1, a1))."""
    q0, q1, a0, a1 = point
    return (q0, -a0), (q1, a1)
