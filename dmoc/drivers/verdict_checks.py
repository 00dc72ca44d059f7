"""The verdict's figures and thresholds (a driver's part), shared by the verdict on R^n
(`dmoc.drivers.verdict`) and on SO(3) x R^n_x (`dmoc.drivers.group_verdict`): the replay's
relative departure, the worst path row at the knots, the worst failed check. Each figure
is relative to the optimum's own scale, so that a problem in millimetres or kilograms gets
the verdict it gets in metres (docs/stages/drivers.md, "Verdicts")."""

import numpy as np

from ..errors import Status
from ..optimal_control.solver.verdict_record import STATUSES
from ..results import figure_rules
from ..results.figure_rules import NO_SCALE, NUMPY  # noqa: F401 (NO_SCALE re-exported)

# A replay on the root IPOPT converged to stays at the solvers' tolerances (1e-16 .. 1e-13
# of the scale on the built-in problems); one on a spurious root by O(1).
REPLAY_TOLERANCE = 1e-6
# A motion of frequency omega changes its step velocity by 2 sin(omega h / 2) of its peak
# per step: more than its own peak (omega h > pi / 3, fewer than 6 steps a period) is not
# resolved; 2 is a reversal every step (aliasing). The built-in problems measure 0.10 to
# 0.55 from 20 steps on, knife-edge parking 1.18 at 10 steps (docs/stages/drivers.md).
JUMP_LIMIT = 1.0
# A knot violates a path constraint when g_k exceeds this part of the row's scale,
# max(1, max_k |g_k|): the NLP imposes the path rows unscaled (`dmoc.optimal_control.nlp.
# scaling`), so 1 in the row's own units is the size IPOPT holds it to; a row whose values
# are larger is measured against them (the same figure in mm as in m).
PATH_TOLERANCE = 1e-6
# A coordinate whose excursion is below this part of its NLP scale (the motion's length
# l_i, or the rest length where nothing moves: `dmoc.optimal_control.nlp.scaling.lengths`) is at rest
# within IPOPT's tolerance; its velocity "jumps" are noise (a hold at the start: 7e-8 rad).
REST_TOLERANCE = 1e-6
# On SO(3), the last knot misses the goal when the angle of R_goal^T R_N (radians) or a
# coordinate of x_N - x_goal over the span of x exceeds this: the NLP holds its goal rows
# to IPOPT's tolerance (1e-10 .. 1e-14 on the built-in problems), an acceptable-level stop
# (`acceptable_constr_viol_tol` 1e-2) or a broken row by far more.
GOAL_TOLERANCE = 1e-6


def worst_status(failed):
    """The first status of `STATUSES` (worst first) whose check failed, ``"passed"`` when
    none did; `failed` maps the statuses checked to whether their check failed."""
    return next((status for status in STATUSES if failed.get(status, False)), Status.PASSED)


def replay_departure(traj, simulated, last):
    """(max |q - q_opt| / span of q, max |p - p_opt| / max |p_opt|, first step beyond
    REPLAY_TOLERANCE or -1) of the optimum `traj` and its replay `simulated` (their ``q``
    (N + 1, n_q), ``p`` (N + 1, n)), comparing the momenta p_0 ... p_{last - 1}; infinite
    when the replay stopped before step N."""
    if simulated.steps < traj.steps:
        return np.inf, np.inf, simulated.steps + 1
    dq = figure_rules.departures(NUMPY, simulated.q, traj.q, q_scale(traj))
    dp = figure_rules.departures(NUMPY, simulated.p[:last], traj.p[:last], scale(np.abs(traj.p).max()))
    beyond = NUMPY.first((dq[:last] > REPLAY_TOLERANCE) | (dp > REPLAY_TOLERANCE))
    return float(dq.max()), float(dp.max()), beyond


def q_scale(traj):
    """The unit of a departure in q: the span of the optimum's configurations (the largest
    max_k q - min_k q), or their size where they do not move (`figure_rules.q_scale`)."""
    return float(figure_rules.q_scale(NUMPY, traj.q))


def scale(*sizes):
    """The first of `sizes` above NO_SCALE, as the unit of a relative departure; 1 (the
    system's units) for an optimum that neither moves nor leaves the origin: there the
    data give no scale (`figure_rules.scale`)."""
    return float(figure_rules.scale(NUMPY, *sizes))


def path_violation(g, name_of, first=0):
    """(largest g_k relative to its row's scale max(1, max_k |g_k|), knot, row, the row's
    name ``name_of(row)``) of the values at the knots `g` (N + 1, rows: path constraints,
    then velocity bounds on R^n), or of its points from `first` on (the point counted from
    there: the rows between the knots, `dmoc.drivers.interpolant_path`) against the scale
    of all of them; (0, -1, -1, "") without rows or violations. The 1 keeps a row that is
    held at zero everywhere (an equality written as the pair g, -g) from being measured
    against its own round-off (`figure_rules.violation`)."""
    value, k, row = figure_rules.violation(NUMPY, g, first)
    return (value, k, row, name_of(row)) if row >= 0 else (0.0, -1, -1, "")


def largest_change(changes, names):
    """(the largest entry of `changes` (K, n), its knot k + 1, the name of its column
    ``names[i]``) of the relative velocity changes at the interior knots; (0, 0, names[0])
    without interior knots (`figure_rules.largest_entry`)."""
    if not changes.size:
        return 0.0, 0, names[0]
    value, k, i = figure_rules.largest_entry(NUMPY, changes)
    return value, k + 1, names[i]
