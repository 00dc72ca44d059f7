"""`dmoc.optimize` of a `GroupOptimalControlProblem` (a driver): IPOPT's optimum on SO(3)
judged by its replay, the optimum's controls simulated from its start by the same group
step residual (`dmoc.simulation.group_stepping`), to REPLAY_TOLERANCE of its scale."""

import numpy as np

from ..errors import InputError, SolverError, Status
from ..optimal_control.solver.group_solving import solve_on_group
from ..simulation.time_stepping import simulate
from .verdict import REPLAY_TOLERANCE

# the keywords of `dmoc.optimize` a problem on the group takes (the others keep their defaults)
GROUP_KEYWORDS = ("options", "throw", "check")


def optimize_on_group(problem, *, options=None, throw=True, check=True, **others):
    """Solve `problem` (`solve_on_group`) and, with `check`, replay it: ``stats``
    gains ``replay_deviation``, max |q_k - q_k'| (R_k and x_k) and max |p_k - p_k'| /
    (1 + max |p|) between the optimum and the simulation of its controls from (q_0, p_0); above
    REPLAY_TOLERANCE the result fails with status ``"not_replayable"`` (raised with
    `throw`). `others` are the other keywords of `dmoc.optimize`, which must keep their
    defaults (refused by name otherwise)."""
    given = sorted(name for name, (value, default) in others.items() if not _is_default(value, default))
    if given:
        raise InputError(f"`dmoc.optimize` of a GroupOptimalControlProblem takes only "
                         f"{', '.join(GROUP_KEYWORDS)}; got {', '.join(given)}.")
    result = solve_on_group(problem, options=options, throw=throw)
    if not (check and result.success):
        return result
    traj = result.trajectory
    q0 = (traj.R[0], traj.x[0]) if problem.disc.system.n_x else traj.R[0]
    replay = simulate(problem.disc, q0=q0, p0=traj.p[0], steps=problem.steps,
                      controls=traj.u, throw=False).trajectory
    k = replay.steps + 1
    deviation = max(float(np.abs(replay.q - traj.q[:k]).max()),
                    float(np.abs(replay.p - traj.p[:k]).max() / (1 + np.abs(traj.p).max())))
    result.stats["replay_deviation"] = deviation if k == traj.steps + 1 else np.inf
    if result.stats["replay_deviation"] > REPLAY_TOLERANCE:
        result.success, result.status = False, Status.NOT_REPLAYABLE
        result.message = (f"the optimum does not replay: simulating its controls departs from it "
                          f"by {result.stats['replay_deviation']:.2e} (limit {REPLAY_TOLERANCE:g}).")
        if throw:
            raise SolverError(result.message, result)
    return result


def _is_default(value, default):
    """Whether a keyword's `value` is its `default` (None, a bool or a number)."""
    return value is default or (type(value) is type(default) and value == default)
