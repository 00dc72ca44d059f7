"""The discrete Dirac structure on SO(3) x R^n_x, left-trivialized (principle stage): the
(+) Dirac differential of a rigid body's discrete Lagrangian in the chart of the group's
own retraction (Cayley), and the membership (36) of every step of a `RotationTrajectory`
in the (+) discrete induced Dirac structure (34), with T*G = G x g* and the annihilator
Delta°(g) = range A(g)^T in the body frame (docs/theory.md, "The discrete Dirac structure
on the group"). `dmoc.dirac.dirac_defect` sends a trajectory on the group here.
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from .._util.numeric import per_step
from ..discrete.group_discretization import GroupDiscretization
from ..errors import InputError
from .annihilator import distance_to_range
from .group_residual import trivialized_derivatives
from .rotation_trajectory import RotationTrajectory

_DIFFERENTIALS = BoundedCache(16, "group_dirac_differentials")


def dirac_differential_on_group(disc):
    """The (+) Dirac differential D+L_d = gamma_d+ o dL_d of a step on the group, with
    forces, in the left trivialization T*G = G x g* and the chart q_k^+ = q_k tau(f) of the
    retraction tau(f) = (cay(f_{1:3}), f_{4:}), as a CasADi Function
    ``(q0, f, u, h) -> (c0, c1, c2, c3)``:

        c0 = q0,  c1 = D2 L_d + f_d^+,  c2 = -D1 L_d - f_d^-,  c3 = q_k^+,

    q0 and c3 (9 + n_x) the rows of R then x, c1 and c2 (3 + n_x) body-frame covectors (the
    left-trivialized D_i L_d = (T_e L_{R_i})^* d_i L_d of `trivialized_derivatives`, the
    ordinary gradient on x), f (3 + n_x) the Cayley coordinates of F_k = R_k^T R_k^+ then
    dx_k. On R^n this is (q0, D2 L_d + f^+, -D1 L_d - f^-, q1) of (15) with (14) [1]_; here
    the fourth component is a point of G, not of the fibre g over c1 (docs/theory.md).

    References
    ----------
    .. [1] M. Leok, T. Ohsawa, "Discrete Dirac structures and implicit discrete Lagrangian
       and Hamiltonian systems", AIP Conf. Proc. 1260 (2010), Section 5.1.
    """
    checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
    return _step_functions(disc)[0]


def _step_functions(disc):
    """(D+L_d, omega_d of a step) as Functions, the second ``(q0, q1, f, h) -> omega_d``
    with F_k = cay(f_{1:3}), built once per body."""
    def build():
        body = disc.system
        q0, q1, f = ca.SX.sym("q0", 9 + body.n_x), ca.SX.sym("q1", 9 + body.n_x), ca.SX.sym("f", body.n)
        u, h = ca.SX.sym("u", body.n_u), ca.SX.sym("h")
        q_plus, F9, D1, D2 = trivialized_derivatives(disc, q0, f, h)
        f_minus, f_plus = disc.discrete_force(q0, q_plus, F9, u, h)
        return (ca.Function("group_dirac_differential", [q0, f, u, h],
                            [q0, D2 + f_plus, -D1 - f_minus, q_plus], ["q0", "f", "u", "h"],
                            ["c0", "c1", "c2", "c3"]),
                ca.Function("omega_d", [q0, q1, f, h], [disc.discrete_constraint(q0, q1, F9, h)],
                            ["q0", "q1", "f", "h"], ["omega_d"]))
    return _DIFFERENTIALS.get(disc.key, build)


def dirac_defect_on_group(disc, traj, tol_rank=1e-12):
    """How far each step of a trajectory on the group is from the (+) discrete Dirac
    structure (34) of the left-trivialized T*G, G = SO(3) x R^n_x, shape (N,).

    Parameters
    ----------
    disc : GroupDiscretization
    traj : RotationTrajectory
        Of `disc`'s body: f (N, 3 + n_x), lam (N, m), u (N, n_u) (the multipliers are not
        read: the annihilator part is a distance to range A^T).
    tol_rank : float
        Relative rank cut of the least-squares projection on range A(q_k)^T.

    Returns
    -------
    numpy.ndarray, shape (N,)
        The max-norm, per step k, of every mismatch of ((z_k, z_{k+1}), D+L_d) against
        (36) with z_k = (q_k, p_k), p_k = (Pi_k, p_x,k):

        - the fourth components: q_{k+1} - c3, the stored next configuration against
          the step's own q_k tau(f_k) (the curve condition q_{k+1} = q_k^+, on the group);
        - the base points over g*: p_{k+1} - c1 = p_{k+1} - D2 L_d - f^+ (37);
        - the annihilator: the distance of p_k - c2 = p_k + D1 L_d + f^- to range
          A(q_k)^T, Delta°(q_k) in the body frame (32);
        - the discrete constraints omega_d(q_k, q_{k+1}) of (28) with the retraction
          of the step, F_k = cay(f_k).

    Raises
    ------
    InputTypeError
        If `disc` is not a GroupDiscretization or `traj` not a RotationTrajectory.
    InputError
        If `traj` does not fit the body of `disc`.
    """
    checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
    checks.instance("traj", traj, RotationTrajectory, "a RotationTrajectory")
    tol_rank = checks.positive_float("tol_rank", tol_rank)
    body, N = disc.system, traj.steps
    for name, size in (("f", body.n), ("lam", body.m), ("u", body.n_u)):
        if getattr(traj, name).shape[1] != size:
            raise InputError(f"`traj.{name}` has {getattr(traj, name).shape[1]} columns; the "
                             f"body {body.name!r} of `disc` has {size}.")
    if N == 0:
        return np.zeros(0)
    q, p = traj.q, traj.p
    differential, constraint = _step_functions(disc)
    _, c1, c2, c3 = per_step(differential, N, q[:-1], traj.f, traj.u, traj.h)
    (omega,) = per_step(constraint, N, q[:-1], q[1:], traj.f, traj.h)
    A = np.array(body.constraint_matrix.map(N)(q[:-1].T))
    off = [distance_to_range(A[:, k * body.n:(k + 1) * body.n].T, p[k] - c2[k], tol_rank)
           for k in range(N)]
    return np.max(np.column_stack([np.abs(q[1:] - c3).max(axis=1), np.abs(p[1:] - c1).max(axis=1),
                                   off, np.abs(omega).max(axis=1, initial=0.0)]), axis=1)
