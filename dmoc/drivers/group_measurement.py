"""What a receding-horizon controller on SO(3) x R^n_x does with a measured state (a
driver: the optimizer in a closed loop): a start (R_0, x_0, p_0) that the NLP of a
`GroupOptimalControlProblem` accepts, R_0 a rotation and the velocity (Omega, x') on the
constraint one-forms A(R_0, x_0), made from a noisy measurement by the policy of
`dmoc.drivers.measurement` (projection, or refusal), with the nearest rotation by polar
decomposition in place of the closest point on g(q) = 0.
"""

import numpy as np

from .._util import checks
from ..errors import InputError
from ..mechanics.given import constraint_violation_tolerance
from ..mechanics.rotations import ORTHOGONALITY_TOLERANCE
from .measurement import MEASUREMENT, Start, measured, projected_velocity, refuse


class GroupMeasurementPolicy:
    """The `measurement` policy of `dmoc.MPC` for a `GroupOptimalControlProblem`: checks a
    measured (R, x) with (Omega, x') or (Pi, p_x) and makes it a start the NLP accepts.

    Parameters
    ----------
    problem : GroupOptimalControlProblem
    policy : {"project", "refuse"}
        "project": R replaced by the nearest rotation and the velocity projected onto
        ker A(R, x) in the metric of the mass matrix M = diag(J, M_x). "refuse":
        InputError naming each violation with its value.

    Notes
    -----
    The nearest rotation to a measured matrix R_m in the Frobenius norm is U diag(1, 1,
    det(U V^T)) V^T, of the singular value decomposition R_m = U S V^T (the orthogonal
    factor of the polar decomposition R_m = Q P when det R_m > 0) [1]_; a matrix with
    |R_m^T R_m - I| above `ORTHOGONALITY_TOLERANCE` (or det R_m <= 0) counts as off
    SO(3), recorded as ``"rotation"``. The velocity is v = v_m - M^-1 A^T (A M^-1
    A^T)^-1 A v_m with A = A(q) at the projected rotation (`projected_velocity`), as on
    R^n (`dmoc.drivers.measurement.MeasurementPolicy`), recorded as ``"velocity"``. A
    measured momentum is kept as on R^n: the first step's left row p_0 - A(q_0)^T lam
    absorbs its component along A^T. A body on the group has no state bounds and no
    holonomic constraints.

    References
    ----------
    .. [1] N. J. Higham, "Matrix nearness problems and applications", in Applications of
       Matrix Theory, Oxford University Press (1989) 1-27 (the orthogonal polar factor).
    """

    def __init__(self, problem, policy):
        self.policy = checks.choice("measurement", policy, MEASUREMENT)
        self.body = problem.disc.system

    def start(self, step, q, v=None, p=None):
        """The start (a `dmoc.drivers.measurement.Start`, q the configuration (rows of R,
        x), shape (9 + n_x,)) of controller step `step` from a measured q, the rotation R
        (3, 3) or the pair (R, x), and the velocity v = (Omega, x') or the momentum p =
        (Pi, p_x), shape (3 + n_x,).

        Raises
        ------
        InputError
            Neither or both of v, p; a wrong shape or a non-finite entry (named, with the
            step); with "refuse", R off SO(3) or v off the constraints.
        """
        n, body = self.body.n, self.body
        if (v is None) == (p is None):
            raise InputError(f"MPC step {step}: give the measured state as `v` or as `p`, exactly one.")
        R_m, x_m = self._configuration(step, q)
        v_m, p_m = (None if w is None else measured(step, name, w, (n,)) for name, w in (("v", v), ("p", p)))
        defect = float(np.abs(R_m.T @ R_m - np.eye(3)).max())
        corrected, R = (), R_m
        if defect > ORTHOGONALITY_TOLERANCE or np.linalg.det(R_m) <= 0:
            refuse(self.policy, step, {"rotation": [f"|R^T R - I| = {defect:.3e}, det R = "
                                                    f"{np.linalg.det(R_m):.6g} (allowed: R in SO(3))"]})
            R, corrected = nearest_rotation(R_m), ("rotation",)
        q, q_m = np.concatenate([R.ravel(), x_m]), np.concatenate([R_m.ravel(), x_m])
        velocity, mass = v_m, np.array(body.generalized_mass(q))
        if v_m is not None:
            A = np.array(body.constraint_matrix(q))
            off = float(np.abs(A @ v_m).max(initial=0.0))
            if off > constraint_violation_tolerance(float(np.abs(v_m).max())):
                refuse(self.policy, step, {"velocity": [f"max abs(A(q) v) = {off:.3e} (allowed: 0, "
                                                        f"v in ker A(q))"]})
                velocity, corrected = projected_velocity(mass, A, v_m), corrected + ("velocity",)
        return Start(q, p_m if v_m is None else mass @ velocity, q_m, v_m, p_m, corrected,
                     float(np.linalg.norm(q - q_m)),
                     0.0 if v_m is None else float(np.linalg.norm(velocity - v_m)))

    def _configuration(self, step, q):
        """(R (3, 3), x (n_x,)) of the measured q: R alone, or the pair (R, x)."""
        if self.body.n_x == 0:
            return measured(step, "q", q, (3, 3)), np.zeros(0)
        if not (isinstance(q, (tuple, list)) and len(q) == 2):
            raise InputError(f"MPC step {step}: `q` must be the pair (R, x) of a rotation (3, 3) "
                             f"and the coordinates ({self.body.n_x},) for {self.body.name!r}; "
                             f"got {type(q).__name__}.")
        return measured(step, "q[0] (R)", q[0], (3, 3)), measured(step, "q[1] (x)", q[1], (self.body.n_x,))


def nearest_rotation(M):
    """The rotation closest to the (3, 3) matrix M in the Frobenius norm, U diag(1, 1,
    det(U V^T)) V^T of M = U S V^T (`GroupMeasurementPolicy`, Notes), shape (3, 3)."""
    U, _, Vt = np.linalg.svd(M)
    return U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
