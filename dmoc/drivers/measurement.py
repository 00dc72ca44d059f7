"""What a receding-horizon controller does with a measured state (a driver: the optimizer
in a closed loop): a start (q_0, p_0) that the problem's NLP accepts, q_0 within
`state_bounds` and on g(q) = 0, the velocity in ker A(q_0), made from a noisy measurement
by a policy chosen once: projection in the metric of the mass matrix, or refusal.
"""

import dataclasses

import casadi as ca
import numpy as np

from .._util import checks
from .._util.numeric import Evaluator
from ..errors import InputError, InputTypeError
from ..mechanics.given import constraint_violation_tolerance, holonomic_residual, numeric
from ..optimal_control.statement.boundary import outside_bounds

MEASUREMENT = ("project", "refuse")
_NEWTON_STEPS = 30      # closest-point iterations on g(q) = 0; noise needs 2-4


@dataclasses.dataclass(frozen=True)
class Start:
    """A measurement made into a start (`MeasurementPolicy.start`).

    Attributes
    ----------
    q, p : ndarray, shape (n,)
        The start the solve uses.
    q_measured : ndarray, shape (n,)
    v_measured, p_measured : ndarray, shape (n,), or None
        The measurement as given (the one of v and p not given is None).
    corrected : tuple of str
        What the measurement violated and the policy corrected, among "state_bounds",
        "holonomic" (g(q) = 0), "rotation" (R off SO(3), `GroupMeasurementPolicy`) and
        "velocity" (A(q) v = 0); empty when it was taken as is.
    q_correction, v_correction : float
        Euclidean norms of q - q_measured and of v - v_measured (0 for a measured p), in
        the coordinates' units.
    """

    q: np.ndarray
    p: np.ndarray
    q_measured: np.ndarray
    v_measured: np.ndarray
    p_measured: np.ndarray
    corrected: tuple
    q_correction: float
    v_correction: float


class MeasurementPolicy:
    """The `measurement` policy of `dmoc.MPC` for one problem: checks a measured (q, v) or
    (q, p) and makes it a start the NLP accepts.

    Parameters
    ----------
    problem : OptimalControlProblem
    policy : {"project", "refuse"}
        "project": q put on g(q) = 0 and clipped to the box of `state_bounds`, v
        projected onto ker A(q), each move the shortest in the metric of the mass matrix
        M = d2L/dv2 (the identity where M is singular or the system Hamiltonian).
        "refuse": InputError naming every violated bound or constraint with its value.

    Notes
    -----
    Without holonomic constraints q is clipped to the box (the closest point in any
    diagonal metric; the entries measured inside it stay as measured). With them, q is
    the closest point to q_m on g = 0, min (q - q_m)^T M (q - q_m) / 2, found by the
    iteration q = q_m - W^-1 J^T (J W^-1 J^T)^-1 (g(q_k) + J (q_m - q_k)), J = dg/dq(q_k)
    (the closest point to q_m on g linearized at q_k, whose fixed point is the exact
    closest point); the entries it leaves outside the box are clipped and held, and the
    iteration runs again on the others (W = M and J restricted to them), until none is
    outside: the closest point within the box when the bounds it holds are the ones
    active there, as they are for noise-sized moves. The velocity is v = v_m - M^-1 A^T (A M^-1
    A^T)^-1 A v_m with A = A(q), the M-orthogonal projection onto ker A: the velocity
    after the constraint impulse A^T lam that removes A v_m, which is what the start rows
    p_0 = p_start make of the momentum M v_m anyway (its component along A(q_0)^T is
    absorbed by the first step's multiplier); the projection makes the correction explicit
    and recorded. A measured p is kept for that reason: no projection of it changes the
    optimum.
    """

    def __init__(self, problem, policy):
        self.policy = checks.choice("measurement", policy, MEASUREMENT)
        self.system = problem.disc.system
        self.lower, self.upper = problem.state_bounds
        n = self.system.n
        self._mass = None
        if hasattr(self.system, "lagrangian"):
            q, v = ca.SX.sym("q", n), ca.SX.sym("v", n)
            hessian = ca.jacobian(self.system.momentum(q, v), v)
            self._mass = Evaluator(ca.Function("mass_matrix", [q, v], [hessian], ["q", "v"], ["M"]))

    def start(self, step, q, v=None, p=None):
        """The start (a `Start`) of controller step `step` from a measured q and v or p,
        shapes (n,).

        Raises
        ------
        InputError
            Neither or both of v, p; a wrong shape or a non-finite entry (named, with the
            step); a measured v on a Hamiltonian system; with "refuse", a measurement
            outside the box or off the constraints; with "project", a configuration the
            box leaves no room to put on g(q) = 0.
        """
        n, system = self.system.n, self.system
        if (v is None) == (p is None):
            raise InputError(f"MPC step {step}: give the measured state as `v` or as `p`, exactly one.")
        if v is not None and self._mass is None:
            raise InputError(f"MPC step {step}: give the measured momentum `p` for a "
                             f"HamiltonianSystem: `v` would need the inverse of v = dH/dp.")
        q_m, v_m, p_m = (None if x is None else measured(step, name, x, (n,))
                         for name, x in (("q", q), ("v", v), ("p", p)))
        violations = self._configuration_violations(q_m)
        if violations:
            self._refuse(step, violations)
        q = self._projected(step, q_m) if violations else q_m
        corrected, v = tuple(violations), v_m
        if v_m is not None:
            A = numeric(system, "constraint_matrix")(q)[0]
            off = float(np.abs(A @ v_m).max(initial=0.0))
            if off > constraint_violation_tolerance(float(np.abs(v_m).max())):
                self._refuse(step, {"velocity": [f"max abs(A(q) v) = {off:.3e} (allowed: 0, "
                                                 f"v in ker A(q))"]})
                v, corrected = projected_velocity(self._metric(q, v_m), A, v_m), corrected + ("velocity",)
            p = numeric(system, "momentum")(q, v)[0].ravel()
        return Start(q, p_m if v_m is None else p, q_m, v_m, p_m, corrected,
                     float(np.linalg.norm(q - q_m)),
                     0.0 if v_m is None else float(np.linalg.norm(v - v_m)))

    def _configuration_violations(self, q):
        """{"state_bounds": [...], "holonomic": [...]}: each violation of the measured q
        in words, with its value and bound; no key without one."""
        names, found = self.system.names, {}
        outside = [f"q[{i}] ({names[i]}) = {x:.6g} {'<' if below else '>'} its "
                   f"{'lower' if below else 'upper'} bound {bound:.6g}"
                   for i, x, below, bound in outside_bounds(q, self.lower, self.upper)]
        if outside:
            found["state_bounds"] = outside
        if self.system.n_holonomic:
            g, off = holonomic_residual(self.system, q)
            if off:
                worst = int(np.argmax(np.abs(g)))
                found["holonomic"] = [f"g(q)[{worst}] = {g[worst]:.3e} (allowed: 0)"]
        return found

    def _refuse(self, step, violations):
        """Raise the InputError of policy "refuse" for `violations` ({what: [words]});
        nothing under "project" (`refuse`)."""
        refuse(self.policy, step, violations)

    def _metric(self, q, v):
        """M(q, v) = d2L/dv2, shape (n, n), or the identity where it is not positive
        definite (a degenerate Lagrangian) or the system Hamiltonian."""
        if self._mass is not None:
            M = self._mass(q, v)[0]
            try:
                np.linalg.cholesky(M)               # raises unless positive definite
                return M
            except np.linalg.LinAlgError:
                pass
        return np.eye(self.system.n)

    def _holonomic_jacobian(self, q):
        """dg/dq(q), shape (k, n): the last k rows of A(q)."""
        return numeric(self.system, "constraint_matrix")(q)[0][self.system.m - self.system.n_holonomic:]

    def _projected(self, step, q_m):
        """The closest q to q_m in the mass-matrix metric within the box and on g(q) = 0
        (Notes of the class)."""
        W = self._metric(q_m, np.zeros_like(q_m))
        q, held = q_m, np.zeros(len(q_m), dtype=bool)
        for _ in range(self.system.n + 1):
            if self.system.n_holonomic:
                q = self._onto_holonomic(step, q_m, q, ~held, W)
            outside = (q < self.lower) | (q > self.upper)
            if not outside.any():
                return q
            q, held = np.clip(q, self.lower, self.upper), held | outside
        raise InputError(f"MPC step {step}: the measured q = {q_m.tolist()} cannot be put on "
                         f"g(q) = 0 within `state_bounds`.")

    def _onto_holonomic(self, step, q_m, q, free, W):
        """q with its `free` entries moved to the closest point to q_m on g = 0 (the held
        entries stay), in the metric W restricted to the free entries."""
        target, W_inv = q.copy(), np.linalg.inv(W[np.ix_(free, free)])
        target[free] = q_m[free]
        for _ in range(_NEWTON_STEPS):
            g, J = numeric(self.system, "holonomic")(q)[0].ravel(), self._holonomic_jacobian(q)[:, free]
            try:
                lam = np.linalg.solve(J @ W_inv @ J.T, g + J @ (target[free] - q[free]))
            except np.linalg.LinAlgError:       # the box holds too many entries
                break
            moved = target[free] - W_inv @ J.T @ lam
            change = float(np.abs(moved - q[free]).max())
            q = q.copy()
            q[free] = moved
            if change <= 1e-14 * max(1.0, float(np.abs(q).max())):
                return q
        if not self._configuration_violations(q).get("holonomic"):     # round-off stalls it
            return q
        raise InputError(f"MPC step {step}: the measured q = {q_m.tolist()} cannot be put on "
                         f"g(q) = 0 with the entries `state_bounds` leaves free (the "
                         f"closest-point iteration fails from there).")



def refuse(policy, step, violations):
    """Raise, under `policy` "refuse", the InputError of controller step `step` listing
    `violations` ({what: [each violation in words]}); nothing under "project"."""
    if policy == "refuse":
        listed = "; ".join(f"{what}: {', '.join(words)}" for what, words in violations.items())
        raise InputError(f"MPC step {step}: the measurement is outside the box or off the "
                         f"constraints ({listed}); with measurement='refuse' it is not "
                         f"used (measurement='project' projects it).")


def projected_velocity(W, A, v_m):
    """v_m - W^-1 A^T (A W^-1 A^T)^-1 A v_m, the W-orthogonal projection of v_m (n,) onto
    ker A (A of shape (m, n), W (n, n) positive definite), shape (n,)."""
    W_inv_AT = np.linalg.solve(W, A.T)
    return v_m - W_inv_AT @ np.linalg.solve(A @ W_inv_AT, A @ v_m)


def measured(step, name, value, shape):
    """The measured `name` as a float array of `shape`, or the InputError naming the step
    and the entry that is wrong (shape, NaN or infinite)."""
    try:
        return checks.array(name, value, shape)
    except (InputError, InputTypeError) as err:
        raise type(err)(f"MPC step {step}: {err}") from None
