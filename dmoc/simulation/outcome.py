"""How a run of the simulator ends, for both configuration spaces (vector spaces,
`time_stepping`, and the rotation group, `group_stepping`): the SimulationResult, and the
verdict on a run from the steps it kept (success, a failed step, an interrupt), raised as
SolverError or `dmoc.Interrupted` with `throw`.
"""

from dataclasses import dataclass, field

import numpy as np

from ..errors import Interrupted, SolverError, Status
from ..principle.trajectory import Trajectory


@dataclass
class SimulationResult:
    """Outcome of `simulate`.

    Attributes
    ----------
    trajectory : Trajectory or RotationTrajectory
        All steps that converged (all of them when `success`); a RotationTrajectory for
        a rigid body on SO(3) (`GroupDiscretization`).
    success : bool
    status : dmoc.Status
        ``"converged"``, ``"newton_failed"``, ``"non_finite"`` (a step produced NaN/Inf)
        or ``"interrupted"`` (Ctrl-C; ``throw=False``).
    message : str
    stats : dict
        ``steps`` requested, ``completed_steps``, ``robust_steps`` (steps the line-search
        Newton redid), ``continued_steps`` (the list of the steps k among those whose root
        Newton found only by continuation in h, from a small step up:
        `dmoc.simulation.continuation`), ``max_residual`` (max-norm of R over the completed steps, checked
        at every step on both paths), ``native`` (True when the fast path ended the run as
        compiled C), ``wall_time`` in seconds (building or loading the compiled step included).
    """

    trajectory: Trajectory
    success: bool
    status: str
    message: str
    stats: dict = field(default_factory=dict)


# the smallest residual relative to the momenta that a converged step can be asked for:
# 100 units of round-off (evaluating R sums and multiplies O(n) terms of size |p|)
ROUNDOFF_FLOOR = 100 * np.finfo(float).eps


def run_stats(steps, k, redone, continued, max_residual, native, wall):
    """A run's ``stats``: of `steps` asked, `k` completed, `redone` of them by the
    line-search Newton, the list of those `continued` (their root found by continuation in
    h), the largest residual, whether the step ran compiled, the wall seconds."""
    return {"steps": steps, "completed_steps": k, "robust_steps": redone, "continued_steps": continued,
            "max_residual": max_residual, "native": native, "wall_time": wall}


def interrupted_result(traj, stats, throw):
    """The result of a run stopped by Ctrl-C after ``stats["completed_steps"]`` accepted
    steps."""
    k = stats["completed_steps"]
    result = SimulationResult(
        traj, False, Status.INTERRUPTED,
        f"interrupted (KeyboardInterrupt) after {k} of {stats['steps']} steps (t = "
        f"{k * traj.h:.6g}); the {k} completed steps are in `.result.trajectory`.", stats)
    if throw:
        raise Interrupted(result.message, result)
    return result


def finished_result(traj, stats, failed_rnorm, tol, throw, hint=None):
    """Report success, or the failed step with the trajectory before it; `hint` is the
    system's reading of the state before a failed step (`RobotSystem.step_failure_hint`),
    None for systems without one."""
    k, steps = stats["completed_steps"], stats["steps"]
    if k == steps:
        return SimulationResult(traj, True, Status.CONVERGED,
                                f"{steps} steps converged (max residual {stats['max_residual']:.2e}).", stats)
    where = f"at step {k} (t = {k * traj.h:.6g})"
    if np.isnan(failed_rnorm):
        status, what = Status.NON_FINITE, (
            f"step {k} turned NaN or Inf (t = {k * traj.h:.6g}): the residual, the next state or "
            f"the multipliers are not finite; "
            + (f"{hint}." if hint else f"check the force and the controls of step {k}."))
    else:
        hint = (f"`tol` = {tol:.1e} is below the round-off floor: 1000 tol is less than the "
                f"{ROUNDOFF_FLOOR:.1e} (100 units of round-off, relative to the momenta) "
                f"that evaluating the residual reaches; use tol >= {ROUNDOFF_FLOOR / 1e3:.1e} "
                f"(default 1e-12)"
                if 1e3 * tol < ROUNDOFF_FLOOR else hint or "try a smaller step h or check the controls")
        status, what = Status.NEWTON_FAILED, (
            f"Newton did not converge {where}: residual max-norm {failed_rnorm:.3e} > 1000 tol "
            f"= {1e3 * tol:.1e} (relative to the momenta) after the iteration limit; {hint}.")
    result = SimulationResult(
        traj, False, status, what + f" The trajectory up to step {k} is in `.result.trajectory`.",
        stats)
    if throw:
        raise SolverError(result.message, result)
    return result
