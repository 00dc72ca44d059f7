"""Discrete Tulczyjew triples (Section 3, eqs. (14)-(17), (21); the maps live in
`dmoc.principle.tulczyjew`) and membership in the discrete induced Dirac structures
(34)/(35), as checkable objects: every step X_d^k of an implicit (+)/(-) discrete
Lagrangian system must satisfy (36)/(40).

Coordinates: z = (q0, p0), z+ = (q1, p1) in T*Q x T*Q with Q = R^n; a point of T*(Q x Q)
is (q0, q1, a0, a1), of T*(Q x Q*) is (q, p, a_q, a_p), of T*(Q* x Q) is (p, q, a_p, a_q).
On SO(3) x R^n_x the (+) membership is checked in the left trivialization by `group_dirac`.
"""

import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from .annihilator import distance_to_range
from .trajectory import check_trajectory, constraint_violation
from ..discrete import Discretization
from ..discrete.group_discretization import GroupDiscretization
from ..errors import InputError
from .formulations import as_formulation
from .group_dirac import dirac_defect_on_group
from .tulczyjew import kappa, kappa_inverse, omega_flat_minus, omega_flat_plus  # noqa: F401 (re-exported)

__all__ = ["kappa", "kappa_inverse", "omega_flat_plus", "omega_flat_minus",
           "dirac_differential", "dirac_defect"]
_DIFFERENTIALS = BoundedCache(32, "dirac_differentials")


def dirac_differential(disc, variant):
    """The Dirac differential of a step's generating function, with forces, as a CasADi
    Function ``(q0, p0, q1, p1, s, u, h) -> (c0, c1, c2, c3)``: a point of T*(Q x Q*) for
    "+" or of T*(Q* x Q) for "-".

    Lagrangian forms: D+-L_d = gamma_d+- o dL_d (Section 5), gamma_d+- = Omega_d+-^flat o
    kappa_d^{-1}, the discrete forces entering dL_d as D1 L_d + f_d^- and D2 L_d + f_d^+:
    "+" gives (q0, D2 L_d + f^+, -D1 L_d - f^-, q1), "-" gives (-D1 L_d - f^-, q1, -q0,
    -D2 L_d - f^+). Hamiltonian forms: dH_d+(q0, p1) = (q0, p1, D1 H_d+ - f_d^-, D2 H_d+)
    of (38), dH_d-(p0, q1) = (p0, q1, D1 H_d-, D2 H_d- - f_d^+) of (42), at the solved
    stages of a stage rule (H_d is extremal in them).
    """
    checks.instance("disc", disc, Discretization, "a Discretization")
    if disc.system.m and disc.rule.has_interior_multipliers:
        raise InputError("`disc` must not have multipliers at interior nodes (a Lagrangian stage "
                         "rule with constraints): its Dirac structure needs the stage-augmented "
                         "annihilator.")
    formulation = as_formulation(variant, disc)
    return _DIFFERENTIALS.get((disc.key, formulation), lambda: formulation.dirac_differential(disc))


def dirac_defect(disc, traj, tol_rank=1e-12):
    """How far each step of `traj` is from the discrete Dirac structure, shape (N,).

    For variant "+" the test is (36): ((z, z+), D+L_d) in D^{d+} of (34), i.e. (q0, q1) in
    Delta_Q^d, the base points of D+L_d and of Omega_d+^flat(z, z+) agree, and their
    difference lies in Delta°_{QxQ*} = {(q, p, A(q)^T lam, 0)} of (32). For "-" it is (40)
    with (35) and Delta°_{Q*xQ} of (33), the annihilator sitting at q1. The defect is the
    max-norm of all those mismatches, the annihilator part measured as the distance to
    range A(q)^T. (In these coordinates the q-components of D+-L_d and Omega_d+-^flat agree
    identically; the content is the p-component, the annihilator and omega_d.)

    A `GroupDiscretization` with a `RotationTrajectory` is checked against the
    left-trivialized (+) structure on SO(3) x R^n_x by
    `dmoc.principle.group_dirac.dirac_defect_on_group`.
    """
    if isinstance(disc, GroupDiscretization):
        return dirac_defect_on_group(disc, traj, tol_rank)
    tol_rank = checks.positive_float("tol_rank", tol_rank)
    if not check_trajectory(disc, traj):
        return np.zeros(0)
    N, formulation = traj.steps, as_formulation(traj.variant, disc)
    alpha = [np.array(c).T for c in dirac_differential(disc, formulation).map(N)(
        traj.q[:-1].T, traj.p[:-1].T, traj.q[1:].T, traj.p[1:].T, traj.s.T, traj.u.T, traj.h)]
    target = formulation.omega_flat((traj.q[:-1], traj.p[:-1]), (traj.q[1:], traj.p[1:]))
    diff = [a - t for a, t in zip(alpha, target)]
    # (34): the fibre over q (component 2) is free up to A(q0)^T lam, the rest must vanish;
    # (35): the fibre over q (component 3) is free up to A(q1)^T lam.
    free = formulation.free_component
    vanish = np.column_stack([np.abs(d).max(axis=1) for i, d in enumerate(diff) if i != free])
    q_ann = (traj.q[:-1], traj.q[1:])[formulation.multiplier_node]
    A = disc.system.constraint_matrix.map(N)(q_ann.T)
    omega = constraint_violation(disc, traj)
    off = [distance_to_range(np.array(A[:, k * disc.system.n:(k + 1) * disc.system.n]).T,
                             diff[free][k], tol_rank) for k in range(N)]
    return np.max(np.column_stack([vanish, off, omega]), axis=1)
