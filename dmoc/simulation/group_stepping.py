"""Consumer 1 of the group step residual: a rigid body simulated on SO(3). Each step solves the
residual's left rows (`dmoc.principle.group_residual`) for the three Cayley coordinates f_k
of the increment F_k = cay(f_k) by the Dirac stepper's Newton paths (`DiracStepper`, its
fast unrolled Newton iterations, compiled horizons and line-search fallback), and
R_{k+1} = R_k F_k, Pi_{k+1} follow explicitly.
"""

import time

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from ..errors import InputError
from ..mechanics.rotations import as_rotation, matrix_of, orthogonalized, vector_of
from ..principle.group_residual import group_step_residual
from ..principle.rotation_trajectory import RotationTrajectory
from .outcome import finished_result, interrupted_result, run_stats
from .preparation import native_choice
from .stepper import DiracStepper, step_layouts


class GroupStepper(DiracStepper):
    """The Dirac stepper on SO(3): the state carries q (the 9 entries of R_k, row after
    row), p (Pi_k, the momentum carried in) and the warm start dq (f_{k-1}); the unknowns
    are f_k (block ``dq``), without multipliers or stages."""

    def _layouts(self):
        return step_layouts(9, 3, 0, 0)

    def _equations(self):
        """G(y, params) -> (g, p0, q1, p1), params = (q0, p0, u, h): the left rows at
        f = y, the momentum, R_{k+1} = R_k cay(f) and Pi_{k+1} (the right rows at p1 = 0)."""
        R = self.residual
        y, q0, p0 = ca.SX.sym("y", 3), ca.SX.sym("q0", 9), ca.SX.sym("p0", 3)
        u, h = ca.SX.sym("u", R.n_controls), ca.SX.sym("h")
        r = R.function(q0, p0, y, ca.SX.zeros(3), u, h)
        q1 = vector_of(orthogonalized(matrix_of(R.reconstruction(q0, y))))
        return ca.Function("step_equations", [y, ca.vertcat(q0, p0, u, h)],
                           [r[R.rows["left"]], p0, q1, r[R.rows["right"]]],
                           ["y", "params"], ["g", "p0", "q1", "p1"])


_STEPPERS = BoundedCache(8, "group_steppers")     # keyed by (residual key, tol, max_iter, native)


def simulate_on_group(disc, *, q0, v0=None, p0=None, steps, controls=None, variant="+",
                      throw=True, tol=1e-12, max_iter=50, jit=None):
    """`dmoc.simulate` of a `GroupDiscretization`: the arguments as there, with q0 the
    rotation R_0 (3, 3), v0 the body angular velocity Omega_0 (3,) (then Pi_0 = J Omega_0)
    or p0 the body angular momentum Pi_0 (3,); ``variant`` "+" and "-" give the same
    steps (no constraints). Returns a SimulationResult whose trajectory is a
    RotationTrajectory."""
    tic = time.perf_counter()
    start = _start(disc, q0, v0, p0)
    steps = checks.positive_int("steps", steps)
    checks.choice("variant", variant, ("+", "-"))
    tol, max_iter = checks.positive_float("tol", tol), checks.positive_int("max_iter", max_iter)
    throw = checks.boolean("throw", throw)
    n_u = disc.system.n_u
    controls = (np.zeros((steps, n_u)) if controls is None
                else checks.array("controls", controls, (steps, n_u)))
    residual, native = group_step_residual(disc), native_choice(jit)
    stepper = _STEPPERS.get((residual.key, tol, max_iter, native),
                            lambda: GroupStepper(residual, tol, max_iter, native))
    acc, out, failed_rnorm, redone, stopped = stepper.run(start, controls, disc.h)
    k = out.shape[0]
    state = stepper.state.split(acc)
    traj = RotationTrajectory(disc.h * np.arange(k + 1), state["q"].reshape(-1, 3, 3), state["p"],
                              state["dq"][1:], controls[:k].copy(), disc.h)
    rnorm = out[:, stepper.out.slice("rnorm")]
    stats = run_stats(steps, k, redone, float(rnorm.max()) if k else 0.0, stepper.native,
                      time.perf_counter() - tic)
    if stopped:
        return interrupted_result(traj, stats, throw)
    return finished_result(traj, stats, failed_rnorm, tol, throw)


def _start(disc, q0, v0, p0):
    """The stepper's start state: the rows of R_0, Pi_0 (J v0 or p0) and the first guess
    f = h J^{-1} Pi_0 (the increment of a step at the start's angular velocity)."""
    J = disc.system.inertia
    R0 = as_rotation("q0", q0)
    if (v0 is None) == (p0 is None):
        raise InputError("give exactly one of `v0` (the body angular velocity Omega_0, shape "
                         "(3,)) and `p0` (the body angular momentum Pi_0, shape (3,)).")
    Pi0 = J @ checks.array("v0", v0, (3,)) if p0 is None else checks.array("p0", p0, (3,))
    return np.concatenate([R0.ravel(), Pi0, disc.h * np.linalg.solve(J, Pi0)])
