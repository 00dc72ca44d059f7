"""The checks of an optimum at its knots (a driver, the verdict's part, `dmoc.drivers.verdict`):
the path constraints and the velocity bounds evaluated at every knot q_k with the knot
velocity, as the NLP's knot rows impose them (their largest violation:
`dmoc.drivers.verdict_checks.path_violation`)."""

import numpy as np

from .._util import checks
from .._util.numeric import mapped
from ..discrete.knot_states import knot_velocities
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from ..principle.rotation_trajectory import RotationTrajectory
from ..results import figure_rules
from ..results.figure_rules import NUMPY
from ..results.knot_velocities import end_velocities
from .group_verdict import group_knot_path_values
from .judged_inputs import check_judged



def knot_path_values(problem, traj):
    """The path constraints g evaluated at every knot, shape (N + 1, rows): at (q_k, v_k,
    u(t_k)), v_k the knot velocity (the mean of the interpolants' velocities at q_k from
    both sides, one side at the ends: `dmoc.discrete.knot_states.knot_velocities`), u(t_k)
    `Trajectory.control` there, with the parameters at q_k (`_knot_arguments`); the values
    the NLP's knot rows impose (`dmoc.optimal_control.nlp.path_terms`). The one-optimum
    case of `knot_path_values_of`. On SO(3), g(R_k, x_k, u_k) (`group_knot_path_values`)."""
    if isinstance(problem, GroupOptimalControlProblem):
        return group_knot_path_values(problem, checks.instance("traj", traj, RotationTrajectory,
                                                               "a RotationTrajectory"))
    check_judged(problem, traj)
    return knot_path_values_of([(problem, traj, end_velocities(problem.disc, traj))])[0]


def knot_path_values_of(triples):
    """`knot_path_values` of each (problem, traj, its `end_velocities`) of `triples`: those
    of one path Function in one call of it mapped over all their knots, their columns
    one optimum after another (a serial map: each optimum's values bit for bit those of
    a call of its own). The mapped Function is kept per path Function and number of
    knots and called through its buffer (`dmoc._util.numeric.mapped`)."""
    found, values = {}, [None] * len(triples)
    for i, (problem, _, _) in enumerate(triples):
        found.setdefault(id(problem.path_constraints), []).append(i)
    for members in found.values():
        path = triples[members[0]][0].path_constraints
        columns = [_knot_arguments(*triples[i]) for i in members]
        total = sum(c[0].shape[1] for c in columns)
        (g,) = mapped(path, total)(*(np.hstack(parts) for parts in zip(*columns)))
        knots = np.cumsum([c[0].shape[1] for c in columns])[:-1]
        for i, block in zip(members, np.split(g.T, knots)):
            values[i] = block
    return values


def _knot_arguments(problem, traj, ends):
    """The arguments (q, v, u, w) of ``problem.path_constraints`` at the N + 1 knots of
    `traj` (`knot_path_values`), one column per knot, from its interpolant's end
    velocities `ends`; w the parameters at each knot (`ProblemParameters.knot_points`, the
    clock with the optimum's step h)."""
    w = problem.parameters.knot_points(traj.h)
    return traj.q.T, knot_velocities(*ends).T, traj.control(traj.t).T, w


def knot_velocity_bound_values(problem, traj, ends=None):
    """The velocity bounds as rows g <= 0 at every knot, shape (N + 1, rows), and their
    names: lower_i - v_k,i and v_k,i - upper_i for each finite bound, v_k the knot velocity
    (`knot_path_values`; `ends` the interpolants' end velocities when computed already).
    InputTypeError on SO(3), as `judge`."""
    check_judged(problem, traj)
    v = knot_velocities(*(end_velocities(problem.disc, traj) if ends is None else ends))
    lower, upper = ((np.flatnonzero(np.isfinite(b)), b[np.isfinite(b)]) for b in problem.velocity_bounds)
    return figure_rules.bound_rows(NUMPY, v, lower, upper), velocity_bound_names(problem)


def velocity_bound_names(problem):
    """The names of the velocity bounds' rows of `knot_velocity_bound_values`, in its
    order: the finite lower bounds, then the finite upper ones."""
    names = problem.disc.system.names
    return [f"velocity_bounds {side} of {names[i]} (v[{i}] {relation} {bound[i]:.6g})"
            for bound, side, relation in zip(problem.velocity_bounds, ("lower", "upper"), (">=", "<="))
            for i in np.flatnonzero(np.isfinite(bound))]
