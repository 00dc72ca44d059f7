"""Consumer 1 of the group step residual: a rigid body simulated on SO(3) x R^n_x. Each step
solves the residual's left and constraint rows (`dmoc.principle.group_residual`) for the
Cayley coordinates f_k of the increment F_k = cay(f_k), the vector increment dx_k and the
multipliers lam_k by the Dirac stepper's Newton paths (`DiracStepper`, its fast unrolled
Newton iterations, compiled horizons and line-search fallback), and R_{k+1} = R_k F_k,
x_{k+1} = x_k + dx_k and the momenta follow explicitly.
"""

import time

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from ..errors import InputError
from ..mechanics.rigid_body import check_allowed_velocity
from ..mechanics.rotations import as_rotation, joined_configuration, orthogonalized, split_configuration
from ..principle.group_residual import group_step_residual
from ..principle.rotation_trajectory import RotationTrajectory
from .outcome import finished_result, interrupted_result, run_stats
from .preparation import native_choice
from .stepper import DiracStepper, step_layouts


class GroupStepper(DiracStepper):
    """The Dirac stepper on SO(3) x R^n_x: the state carries q (the 9 entries of R_k, row
    after row, then x_k), p (the momentum (Pi_k, p_x,k) carried in) and the warm start dq
    (the previous increment (f, dx)) and nu (the previous multipliers); the unknowns are
    the increment (block ``dq``) and lam_k (block ``nu``), without stages."""

    def _layouts(self):
        R = self.residual
        return step_layouts(R.inputs.numel("q0"), R.n, R.m, 0)

    def _equations(self):
        """G(y, params) -> (g, p0, q1, p1), params = (q0, p0, u, h): the left and constraint
        rows at y = (f, dx, lam), the momentum, q_{k+1} (R_k cay(f), one Bjorck-Bowie step,
        and x_k + dx) and p_{k+1} (the right rows at p1 = 0)."""
        R = self.residual
        y, p0 = ca.SX.sym("y", self.unknowns.size), ca.SX.sym("p0", R.n)
        q0 = ca.SX.sym("q0", R.inputs.numel("q0"))
        u, h = ca.SX.sym("u", R.n_controls), ca.SX.sym("h")
        Y = self.unknowns.split(y)
        r, q1 = R.stepped(q0, p0, Y["dq"], ca.SX.zeros(R.n), Y["nu"], u, h)
        R1, x1 = split_configuration(q1)
        q1 = joined_configuration(orthogonalized(R1), x1)
        return ca.Function("step_equations", [y, ca.vertcat(q0, p0, u, h)],
                           [ca.vertcat(r[R.rows["left"]], r[R.rows["constraint"]]), p0, q1,
                            r[R.rows["right"]]], ["y", "params"], ["g", "p0", "q1", "p1"])


_STEPPERS = BoundedCache(8, "group_steppers")     # keyed by (residual key, tol, max_iter, native)


def simulate_on_group(disc, *, q0, v0=None, p0=None, steps, controls=None, variant="+",
                      throw=True, tol=1e-12, max_iter=50, jit=None):
    """`dmoc.simulate` of a `GroupDiscretization`: the arguments as there, with q0 the
    rotation R_0 (3, 3), or the pair (R_0, x_0) of a body with coordinates; v0 the
    velocity (Omega_0, x'_0) (3 + n_x,) (then p_0 = M(q_0) (Omega_0, x'_0), M the body's
    `generalized_mass`) or p0 the momentum (Pi_0, p_x,0) (3 + n_x,), whose velocity must
    satisfy the constraints.
    ``variant`` "+" and "-" give the same steps without constraints; with constraints
    only "+" (the multiplier at q_k) is built. Returns a SimulationResult whose
    trajectory is a RotationTrajectory."""
    tic = time.perf_counter()
    body = disc.system
    checks.choice("variant", variant, ("+", "-") if body.m == 0 else ("+",))
    start = _start(disc, q0, v0, p0)
    steps = checks.positive_int("steps", steps)
    tol, max_iter = checks.positive_float("tol", tol), checks.positive_int("max_iter", max_iter)
    throw = checks.boolean("throw", throw)
    n_u = body.n_u
    controls = (np.zeros((steps, n_u)) if controls is None
                else checks.array("controls", controls, (steps, n_u)))
    residual, native = group_step_residual(disc), native_choice(jit)
    stepper = _STEPPERS.get((residual.key, tol, max_iter, native),
                            lambda: GroupStepper(residual, tol, max_iter, native))
    acc, out, failed_rnorm, redone, stopped, continued = stepper.run(start, controls, disc.h)
    k = out.shape[0]
    state = stepper.state.split(acc)
    q, p = state["q"], state["p"]
    traj = RotationTrajectory.unchecked(disc.h * np.arange(k + 1), q[:, :9].reshape(-1, 3, 3),
                                        p[:, :3], state["dq"][1:], controls[:k].copy(), disc.h,
                                        q[:, 9:], p[:, 3:], out[:, stepper.out.slice("nu")])
    rnorm = out[:, stepper.out.slice("rnorm")]
    stats = run_stats(steps, k, redone, continued, float(rnorm.max()) if k else 0.0, stepper.native,
                      time.perf_counter() - tic)
    if stopped:
        return interrupted_result(traj, stats, throw)
    explain = getattr(body, "step_failure_hint", None)     # a FloatingBaseRobot's reading
    hint = explain(q[k], p[k], disc.h) if explain and k < steps else None
    return finished_result(traj, stats, failed_rnorm, tol, throw, hint)


def _start(disc, q0, v0, p0):
    """The stepper's start state: q_0 = (rows of R_0, x_0), p_0 (the momentum of v0, or
    p0), the first guess of the increment h M^{-1} p_0 (a step at the start's velocity)
    and of the multipliers, 0."""
    body = disc.system
    q = start_configuration(body, q0)
    if (v0 is None) == (p0 is None):
        raise InputError(f"give exactly one of `v0` (the velocity (Omega_0, x'_0), shape "
                         f"({body.n},)) and `p0` (the momentum (Pi_0, p_x,0), shape ({body.n},)).")
    mass = np.array(body.generalized_mass(q))
    v = checks.array("v0", v0, (body.n,)) if p0 is None else \
        np.linalg.solve(mass, checks.array("p0", p0, (body.n,)))
    check_allowed_velocity(body, q, v, "`v0` (or of `p0`) at `q0`")
    return np.concatenate([q, mass @ v, disc.h * v, np.zeros(body.m)])


def start_configuration(body, q0):
    """q_0 = (rows of R_0, x_0) from `q0`: the rotation R_0 (3, 3), or the pair (R_0, x_0)
    of a body with coordinates."""
    if body.n_x == 0:
        return as_rotation("q0", q0).ravel()
    if not (isinstance(q0, (tuple, list)) and len(q0) == 2):
        raise InputError(f"`q0` must be the pair (R_0, x_0) of a rotation (3, 3) and the "
                         f"coordinates ({body.n_x},) for {body.name!r}; got {type(q0).__name__}.")
    return np.concatenate([as_rotation("q0", q0[0]).ravel(), checks.array("q0", q0[1], (body.n_x,))])
