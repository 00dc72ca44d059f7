"""What a receding-horizon controller solves on SO(3) x R^n_x (a driver: the optimizer in
a closed loop): the NLP of a `GroupOptimalControlProblem` transcribed once, its start
(R_0, x_0, p_0) fixed by the bounds of each step, solved by one kept IPOPT solver (two: the
first, cold, solve's and the warm one's), each solve after the first from the previous
optimum moved on along its own group increments (`dmoc.drivers.horizon_shift`).
"""

import numpy as np

from .._util import checks
from ..errors import InputError
from ..optimal_control.nlp.group_transcription import group_transcription
from ..optimal_control.solver.group_solving import geodesic_guess, solve_with
from .group_measurement import GroupMeasurementPolicy
from .horizon_shift import shifted_on_group


class GroupHorizon:
    """`MPC`'s horizon on the group: the arguments are `MPC`'s, with `guess` and
    `references` None and `jit` None or False (refused by name otherwise: a problem on the group
    has no parameters and starts along the geodesic; with `jit` None its NLP is compiled in
    the background once its warm steps have spent `COMPILE_AFTER_SECONDS` in IPOPT, as on
    R^n, `dmoc.optimal_control.nlp.evaluation`). `expand` as on R^n.

    Attributes
    ----------
    problem : GroupOptimalControlProblem
        As given: its start data are replaced by each measurement in the NLP's bounds.
    measurement : GroupMeasurementPolicy
    """

    def __init__(self, problem, guess, options, measurement, references, switches):
        for name, value, default in (("guess", guess, None), ("references", references, None),
                                     ("jit", switches["jit"] or None, None)):
            if value is not default:
                raise InputError(f"`{name}` is not taken by MPC of a GroupOptimalControlProblem "
                                 f"(it has no parameters and starts along the geodesic, its NLP "
                                 f"compiled on its own with jit=None); leave it at {default!r}.")
        self.problem, self.measurement = problem, GroupMeasurementPolicy(problem, measurement)
        self._T = group_transcription(problem)
        self._options = {} if options is None else checks.ipopt_options("options", options)
        self._switches = switches
        self._bounds = (self._T.lbx.copy(), self._T.ubx.copy())
        layout = self._T.x_layout
        self._fixed = np.concatenate([layout.slice(name).start + np.arange(size)
                                      for name, size in (("q", 9 + problem.disc.system.n_x),
                                                         ("p", problem.disc.system.n))])

    def restate(self, step, start, parameters):
        """Fix q_0 and p_0 of the NLP at the start of step `step` (`parameters` refused)."""
        if parameters:
            raise InputError(f"MPC step {step}: `parameters` must be None for a "
                             f"GroupOptimalControlProblem, which has none.")
        for bound in self._bounds:
            bound[self._fixed] = np.concatenate([start.q, start.p])

    def solve(self, plan, by, start):
        """The solve from the geodesic (the first), or from `plan` moved `by` steps on
        and carried onto the start (`shifted_on_group`), primal and dual; its
        ``stats["build_time"]`` the seconds spent creating the solver (0 when kept,
        `solve_with`)."""
        warm = plan is not None
        point = (shifted_on_group(plan, self._T, self.problem.steps, by, start.q) if warm
                 else {"x0": geodesic_guess(self.problem, self._T)})
        return solve_with(self.problem, self._T, self._options,
                          {**point, "lbx": self._bounds[0], "ubx": self._bounds[1]},
                          throw=False, warm_start=warm, **self._switches)

    def controls(self, plan, age):
        """The controls u_age of `plan`, shape (n_u,)."""
        return self._T.x_layout.unpack(plan.x, "u")[:, age].copy()

    def step_length(self, plan):
        """The discretization's h."""
        return self.problem.disc.h

    def advance(self, h):
        """Nothing: no references, no clock."""
