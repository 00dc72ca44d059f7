"""The terms of the DMOC NLP that hold the motion's limits (consumer 2 of the step residual):
the user's path constraints g(q, v, u) <= 0 and the velocity bounds lower <= v <= upper, at
each step's interior points and at every knot q_0 ... q_N, where the verdict checks them
(`dmoc.drivers.verdict`). The velocities are those of `dmoc.discrete.knot_states`, one
definition for both: at a knot the mean of the two interpolants' end velocities (one side
at q_0 and q_N), inside a step the interpolant's velocity (docs/stages/optimize.md, "Path
constraints and velocity bounds").

Which rows are where (g blocks of `Transcription.g_layout`):

- ``path`` (points * rows, N): g at each step's interior points on the rule's
  interpolant, (q(t_k + c h), q'(t_k + c h), u(t_k + c h), w(t_k + c h)) for c in
  `knot_states.interior_points` (the stage nodes, or the midpoint of a linear rule),
  point by point, w the parameters at the fraction c of the step (`ParameterSchedule.at`);
- ``path_knots`` (rows, N + 1): every row of g at every knot, (q_k, v_k, u(t_k), w(t_k)),
  v_k the knot velocity, u(t_k) the control of the step that starts there (of the last step
  at q_N), as `Trajectory.control` reads it, and w(t_k) the parameters there
  (`ProblemParameters.knot_points`);
- ``velocity_steps`` (points * bounded, N): the bounded entries of the interpolant's
  velocity at the step's interior points (`knot_states.interior_points`: the stage nodes, or
  the midpoint of a linear rule, whose step velocity (q_{k+1} - q_k)/h is the velocity of
  the whole step);
- ``velocity_knots`` (bounded, N + 1): the bounded entries of v_k, for rules with stage
  nodes; a linear rule's v_k is the mean of two step velocities (one at the ends), inside
  the box whenever they are, so those rows would repeat ``velocity_steps``.
"""

import casadi as ca
import numpy as np

from ...discrete.knot_states import (end_velocity_function, interior_points,
                                     interior_state_function, knot_velocity)


def row_counts(rule, rows, bounded):
    """{block: rows per step or knot} of ``path``, ``path_knots``, ``velocity_steps`` and
    ``velocity_knots`` for `rule` with `rows` path constraint rows and `bounded` velocity
    entries (counts): every interior point's, and the knots' (of the velocities only for a
    rule with stage nodes)."""
    points = len(interior_points(rule))
    return {"path": points * rows, "path_knots": rows, "velocity_steps": points * bounded,
            "velocity_knots": bounded if rule.stage_nodes else 0}


def _slots(slots, *unread):
    """The slots of a `_StepSlots.at` dict that a path or velocity row reads: all but the
    multipliers (lam) and those named in `unread`."""
    return {k: v for k, v in slots.items() if not k.startswith("lam") and k not in unread}


def path_terms(step, G):
    """The terms of blocks ``path``, ``velocity_steps`` and the knot rows
    (``path_knots`` with ``velocity_knots``) of the problem of `step` (`terms._StepSlots`),
    G the row indices by block; none for an empty block."""
    problem, N = step.problem, step.N
    disc, path = problem.disc, problem.path_constraints
    rule, n = disc.rule, disc.system.n
    bounded = list(problem.velocity_bounded)
    points, terms = interior_points(rule), []
    inside = interior_state_function(rule, n, disc.n_stages)
    parameters_at = problem.parameters.schedule.at
    if G["path"].size:
        def middle(s):
            q, v = inside(s["q0"], s["q1"], s["s"], s["h"])
            at = [slice(j * n, (j + 1) * n) for j in range(len(points))]
            return 0, ca.vertcat(*[path(q[j], v[j], rule.control_at(s["u"], c),
                                        parameters_at(s["w"], c, s["h"])) for j, c in zip(at, points)])
        terms.append(step.term("path", _slots(step.at(0, N)), middle, G["path"]))
    if G["velocity_steps"].size:
        entries = [j * n + i for j in range(len(points)) for i in bounded]

        def interior(s):
            return 0, inside(s["q0"], s["q1"], s["s"], s["h"])[1][entries]
        terms.append(step.term("velocity_steps", _slots(step.at(0, N), "w"), interior, G["velocity_steps"]))
    rows = np.vstack([G["path_knots"], G["velocity_knots"]])
    if rows.size:
        terms += _knot_terms(step, rows, G["velocity_knots"].size > 0)
    return terms


def _knot_terms(step, rows, velocity_rows):
    """The terms of the knot rows `rows` (row indices (r, N + 1): the path constraints, then
    the bounded velocities when `velocity_rows`) at q_0, at q_1 ... q_{N-1} (two steps
    each: the knot velocity reads both interpolants) and at q_N. The parameters at q_k are
    those of the step that starts there at its start (of the last step at its end at q_N),
    as `ProblemParameters.knot_points` gives them: a per-knot value is the same from both
    sides, a per-step one that of the step that starts at the knot, as its control is."""
    problem, N = step.problem, step.N
    disc, path = problem.disc, problem.path_constraints
    ends = end_velocity_function(disc.rule, disc.system.n, disc.n_stages)
    bounded = list(problem.velocity_bounded) if velocity_rows else []
    control_at, parameters_at = disc.rule.control_at, problem.parameters.schedule.at

    def at_knot(q, v, u, s, c):
        w = parameters_at(s["w"], c, s["h"])
        rows = [path(q, v, u, w)] if path is not None else []
        return ca.vertcat(*rows, *([v[bounded]] if bounded else []))     # v[[]] of n = 1 is 1 x 0

    def first(s):
        start = ends(s["q0"], s["q1"], s["s"], s["h"])[0]
        return 0, at_knot(s["q0"], start, control_at(s["u"], 0.0), s, 0.0)

    def interior(s):
        arriving = ends(s["q0_before"], s["q1_before"], s["s_before"], s["h"])[1]
        leaving = ends(s["q0"], s["q1"], s["s"], s["h"])[0]
        return 0, at_knot(s["q0"], knot_velocity(arriving, leaving), control_at(s["u"], 0.0), s, 0.0)

    def last(s):
        end = ends(s["q0"], s["q1"], s["s"], s["h"])[1]
        return 0, at_knot(s["q1"], end, control_at(s["u"], 1.0), s, 1.0)
    terms = [step.term("knot_first", _slots(step.at(0, 1)), first, rows[:, :1]),
             step.term("knot_last", _slots(step.at(N - 1, N)), last, rows[:, N:])]
    if N > 1:
        slots = {**_slots(step.at(0, N - 1, "_before"), "u_before", "w_before"), **_slots(step.at(1, N))}
        terms.append(step.term("knots", slots, interior, rows[:, 1:N]))
    return terms
