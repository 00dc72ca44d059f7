"""Discretization stage: the velocity of a discrete trajectory where it is checked, one
definition for the optimizer's rows (velocity bounds and path constraints at the knots,
`dmoc.optimal_control.nlp.terms`) and the verdict's checks of an optimum
(`dmoc.drivers.verdict`). Each step's interpolant, the rule's polynomial through q_k, the
stage configurations and q_{k+1} (`Rule.interpolant`, on which the action sum (46)/(47)
evaluates L), has a velocity at both ends; at an interior knot the two meet with a jump of
the rule's order, and the knot velocity is their mean (one side at q_0 and at q_N). Inside a
step the velocity is read at its interior points: the stage nodes of a stage rule, the
midpoint of a linear rule (where the step velocity (q_{k+1} - q_k)/h is the interpolant's).
"""

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache

_END_VELOCITIES = BoundedCache(32, "end_velocities")    # keyed by (rule, n, stage rows): not per N or h
_INTERIOR_STATES = BoundedCache(32, "interior_states")


def end_velocity_function(rule, n, n_stages):
    """The Function ``(q0, q1, s, h) -> (start, end)``, shapes (n,): the velocities
    q'(0) and q'(h) of one step's interpolant under `rule` for n coordinates and
    `n_stages` stage rows; both (q1 - q0)/h for the midpoint and trapezoid rules. Built once
    per (rule, n, n_stages) and kept (cache ``"end_velocities"``)."""
    def build():
        q0, q1, s, h = (ca.SX.sym(name, size) for name, size in
                        (("q0", n), ("q1", n), ("s", n_stages), ("h", 1)))
        ends = rule.interpolant.samples(q0, q1, rule.stage_configurations(s, n), h,
                                        ((0.0, 1.0), (1.0, 1.0)))
        return ca.Function("end_velocities", [q0, q1, s, h], [ends[0][2], ends[1][2]],
                           ["q0", "q1", "s", "h"], ["start", "end"])
    return _END_VELOCITIES.get((rule, n, n_stages), build)


def knot_velocity(arriving, leaving):
    """The velocity at an interior knot q_k, shape of its arguments: the mean of the
    interpolants' velocities there, `arriving` q'_{k-1}(h) of step k - 1 and `leaving`
    q'_k(0) of step k (numbers, arrays or CasADi expressions)."""
    return (arriving + leaving) / 2


def knot_velocities(start, end):
    """The velocities v_0 ... v_N at the knots, shape (N + 1, n), from the interpolants'
    end velocities `start` q'_k(0) and `end` q'_k(h), shapes (N, n)
    (`end_velocity_function`): q'_0(0) at q_0, `knot_velocity` at q_1 ... q_{N-1} and
    q'_{N-1}(h) at q_N."""
    return np.vstack([start[:1], knot_velocity(end[:-1], start[1:]), end[-1:]])


def interior_points(rule):
    """The step times c in (0, 1) where a step's velocity is read besides its ends, a tuple
    of float: the rule's stage nodes, or the midpoint (0.5,) for a rule without them."""
    return tuple(rule.stage_nodes) or (0.5,)


def interior_state_function(rule, n, n_stages):
    """The Function ``(q0, q1, s, h) -> (q, v)``, shapes (len(interior_points) * n,): the
    configuration and the velocity of one step's interpolant at each of
    `interior_points(rule)`, point by point. Built once per (rule, n, n_stages) and kept
    (cache ``"interior_states"``)."""
    def build():
        q0, q1, s, h = (ca.SX.sym(name, size) for name, size in
                        (("q0", n), ("q1", n), ("s", n_stages), ("h", 1)))
        samples = rule.interpolant.samples(q0, q1, rule.stage_configurations(s, n), h,
                                           tuple((c, 1.0) for c in interior_points(rule)))
        return ca.Function("interior_states", [q0, q1, s, h],
                           [ca.vertcat(*[q for _, q, _, _ in samples]),
                            ca.vertcat(*[v for _, _, v, _ in samples])], ["q0", "q1", "s", "h"], ["q", "v"])
    return _INTERIOR_STATES.get((rule, n, n_stages), build)
