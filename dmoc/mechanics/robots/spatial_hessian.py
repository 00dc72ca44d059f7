"""The second derivatives of a fixed-base robot's Lagrangian, for the mechanics stage, as
its second variation along two directions in (q, v) (`second_variation`: the mass matrix,
d^2L/dq^2, d^2L/dq dv, or a combination of them, such as the midpoint step's Jacobian):
after two O(n) passes over the kinematic tree, four dot products of spatial vectors per pair
of joints, so O(n^2) for the n x n matrix with a small constant, where automatic
differentiation of the links' recursion (`link_recursion`) costs about 0.7 n sweeps through
the gradient of L. The step's chord takes it (`dmoc.simulation.step_jacobian`).

Spatial vectors in the base's frame at its origin (Featherstone [1]_): a motion m = (w, v),
v the velocity of the body point at the origin, a force f = (n, f), n the moment about the
origin; m1 x m2 = (w1 x w2, w1 x v2 + v1 x w2) and m x* f = (w x n + v x f, w x f). A
joint's motion subspace S_i (a unit twist: (a, p x a) for a revolute joint of axis a
through p, (0, a) for a prismatic one) turns with its ancestors, dS_i/dq_j = S_j x S_i,
and an inertia with the joints below it, dI/dq_j = S_j x* I - I S_j x (Carpentier and
Mansard [2]_, who differentiate the recursive Newton-Euler algorithm so). Differentiating
L_v_i = S_i . h^C_i and L_q_i = -psi_i . h^C_i - S_i . I^C_i a_0 once more with them gives,
for joints j and i with j an ancestor of i or i itself (j <= i),

    M_ij      = S_j . F_i,                          F_i = I^C_i S_i,
    L_q_i q_j = -psi_j . gamma_i + alpha_j . F_i,    psi_i = S_i x V_lambda(i),
    L_q_i v_j = S_j . gamma_i,                       gamma_i = S_i x* h^C_i - I^C_i psi_i,
    L_q_j v_i = -psi_j . F_i,                        alpha_j = S_j x a_0,

and 0 for joints on different branches; I^C_i is the composite inertia of the subtree carried
by joint i, h^C_i its spatial momentum, V_lambda(i) the velocity of joint i's parent link
and a_0 = (0, 0, 0, 0, 0, g) gravity as an acceleration of the base. The tests check them
against Pinocchio's CRBA, RNEA and gravity derivatives and the Hessian of L.

References
----------
.. [1] R. Featherstone, Rigid Body Dynamics Algorithms, Springer, 2008, ch. 2 and 5.
.. [2] J. Carpentier and N. Mansard, "Analytical derivatives of rigid body dynamics
   algorithms", Robotics: Science and Systems, 2018.
"""

import casadi as ca

from .link_recursion import PRISMATIC, REVOLUTE, joint_transform


def motion_cross(a, b):
    """a x b of two motion vectors (6, 1): (w_a x w_b, w_a x v_b + v_a x w_b)."""
    return ca.vertcat(ca.cross(a[:3], b[:3]), ca.cross(a[:3], b[3:]) + ca.cross(a[3:], b[:3]))


def force_cross(a, f):
    """a x* f of a motion vector a and a force f (6, 1): (w x n + v x f, w x f)."""
    return ca.vertcat(ca.cross(a[:3], f[:3]) + ca.cross(a[3:], f[3:]), ca.cross(a[:3], f[3:]))


def inertia_times(inertia, m):
    """I m of a spatial inertia (mass, first moment m c (3, 1), rotational inertia about the
    origin (3, 3)) and a motion m = (w, v): (I_O w + m c x v, mass v - m c x w), (6, 1)."""
    mass, moment, rotational = inertia
    w, v = m[:3], m[3:]
    return ca.vertcat(ca.mtimes(rotational, w) + ca.cross(moment, v), mass * v - ca.cross(moment, w))


def second_variation(links, q, v, gravity, a, b):
    """The second variation of L = T - V of the tree `links` on a fixed base along the
    directions a and b, by the formulas of the module's notes: the (n, n) matrix

        W[i, j] = (a_q d/dq_i + a_v d/dv_i)(b_q d/dq_j + b_v d/dv_j) L
                = a_q b_q L_q_i q_j + a_q b_v L_q_i v_j + a_v b_q L_v_i q_j + a_v b_v M_ij,

    e.g. a = b = (0, 1) gives M(q), a = (1, 0), b = (0, 1) the block d^2L/dq dv, and
    h (1/2, -1/h), (1/2, 1/h) the midpoint rule's D2 D1 L_d (`dmoc.simulation.step_jacobian`).
    Per pair of joints j <= i, four dot products of 6-vectors give W[i, j] and W[j, i]:
    F_i . beta_j, psi_j . gamma_i, S_j . gamma_i and psi_j . F_i, beta_j = a_q b_q alpha_j
    + a_v b_v S_j.

    Parameters
    ----------
    links : sequence of dmoc.mechanics.robots.link_recursion.Link
        Parents before children, the base first (at rest, its frame the world's).
    q, v : casadi.SX, shape (n, 1)
        Joint positions and velocities, in the order of the links' ``index``.
    gravity : float
        g, along -z of the base's frame.
    a, b : pair of float or casadi.SX
        (a_q, a_v) and (b_q, b_v), the weights of the positions and velocities in each
        direction.

    Returns
    -------
    casadi.SX, shape (n, n)
    """
    frames, joints = _forward(links, q, v)
    composite = _composite(links, frames)
    a0 = ca.SX([0.0, 0.0, 0.0, 0.0, 0.0, gravity])
    (a_q, a_v), (b_q, b_v) = a, b
    w_qq, w_qv, w_vq, w_vv = a_q * b_q, a_q * b_v, a_v * b_q, a_v * b_v
    rows, columns = {}, {}      # joint index -> (F, gamma) and (beta, psi, S) it is dotted with
    for k, S in joints.items():
        inertia, momentum = composite[k]
        psi = motion_cross(S, frames[links[k].parent][2])
        gamma = force_cross(S, momentum) - inertia_times(inertia, psi)
        rows[links[k].index] = (inertia_times(inertia, S), gamma)
        columns[links[k].index] = (w_qq * motion_cross(S, a0) + w_vv * S, psi, S)
    W = ca.SX.zeros(q.numel(), q.numel())
    for k in joints:            # row i and column i over the ancestors j, as 1 x k products
        i, js = links[k].index, _moving_ancestors(links, k)
        F_i, gamma_i = (x.T for x in rows[i])
        beta, psi, S = (ca.horzcat(*[columns[j][m] for j in js]) for m in range(3))
        common = ca.mtimes(F_i, beta) - w_qq * ca.mtimes(gamma_i, psi)
        d3, d4 = ca.mtimes(gamma_i, S), ca.mtimes(F_i, psi)
        W[js, i] = (common + w_vq * d3 - w_qv * d4).T
        W[i, js] = common + w_qv * d3 - w_vq * d4       # the diagonal entry from this row
    return W


def _forward(links, q, v):
    """The forward pass: per link (R, p, V), its orientation and origin in the base's frame
    and its spatial velocity; and {link: S} the motion subspace of each moving joint."""
    frames, joints = [], {}
    for k, link in enumerate(links):
        if link.parent is None:
            frames.append((ca.SX.eye(3), ca.SX.zeros(3), ca.SX.zeros(6)))
            continue
        R_p, p_p, V = frames[link.parent]
        R_j, o = joint_transform(link, q)
        R, p = ca.mtimes(R_p, R_j), p_p + ca.mtimes(R_p, o)
        if link.kind in REVOLUTE or link.kind == PRISMATIC:
            a = ca.mtimes(R, ca.SX(link.axis))
            S = ca.vertcat(a, ca.cross(p, a)) if link.kind in REVOLUTE else ca.vertcat(ca.SX.zeros(3), a)
            joints[k] = S
            V = V + S * v[link.index]
        frames.append((R, p, V))
    return frames, joints


def _composite(links, frames):
    """The backward pass: per link, (its subtree's spatial inertia (mass, first moment,
    rotational inertia about the origin), its subtree's spatial momentum), in the base's
    frame."""
    inertias, momenta = [], []
    for link, (R, p, V) in zip(links, frames):
        c = p + ca.mtimes(R, ca.SX(link.center))
        moment = link.mass * c          # I_O = R I_c R^T + m (|c|^2 1 - c c^T)
        rotational = (_symmetric(ca.mtimes(R, ca.SX(link.inertia)), R) - _symmetric(moment, c)
                      + ca.dot(moment, c) * ca.SX.eye(3))
        inertia = (ca.SX(link.mass), moment, rotational)
        inertias.append(inertia)
        momenta.append(inertia_times(inertia, V))
    for k in reversed(range(1, len(links))):
        parent = links[k].parent
        inertias[parent] = tuple(a + b for a, b in zip(inertias[parent], inertias[k]))
        momenta[parent] = momenta[parent] + momenta[k]
    return list(zip(inertias, momenta))


def _symmetric(A, B):
    """A B^T (3, 3) for a product known to be symmetric (A and B of shape (3, 3), or (3, 1)
    for an outer product a b^T), SX: its upper triangle mirrored, so that only its 6
    distinct entries are computed."""
    product = ca.mtimes(A, B.T)
    return ca.triu(product) + ca.triu(product, False).T


def _moving_ancestors(links, k):
    """The coordinates of the moving joints from link k (itself included) down to the base."""
    found = []
    while links[k].parent is not None:
        if links[k].index is not None and links[k].kind != "fixed":
            found.append(links[k].index)
        k = links[k].parent
    return found
