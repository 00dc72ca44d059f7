"""The copies of an OptimalControlProblem with some of its data changed (consumer 2 of the
step residual, its statement): new boundary data or parameter values on the same NLP, another
N or another rule on a new one. `OptimalControlProblem` takes these methods from
`ProblemCopies`.
"""

from ..._util import checks
from ...discrete import discretize
from .boundary import set_boundary
from .final_time import FixedFinalTime
from .rule_parts import rule_parts
from ..nlp.transcription import Transcription


class ProblemCopies:
    """The `with_*` methods of `OptimalControlProblem`: each returns a copy whose NLP
    (`transcription`) is this problem's with new bounds, or a new one."""

    def _copy(self):
        """A shallow copy, its attributes this problem's until set anew (as `copy.copy`
        makes it, without its protocol's calls: a re-solve's `with_boundary` pays it)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        return new

    def with_boundary(self, *, q_start=None, q_goal=None, v_start=None, v_goal=None, p_start=None):
        """This problem with new boundary data; arguments left None keep this problem's
        (a given `p_start` replaces the start velocity, a given `v_start` the start
        momentum).

        The boundary data enter the NLP only through the bounds lbx = ubx (and p_start
        through p), so the copy shares this problem's NLP (and `structure`, hence its
        compiled solver and a warm start from this problem's optimum) unless an end changes
        between fully given and partly free with a nonzero or free velocity (then the
        velocity rows A(q) v = 0 appear or vanish), or the start changes between a velocity
        and a momentum: then the NLP is rebuilt.

        Examples
        --------
        >>> import dmoc, dmoc.problems
        >>> problem = dmoc.problems.knife_edge_parking(20)
        >>> moved = problem.with_boundary(q_goal=[0.2, 1.0, 0.0])
        >>> moved.q_goal.tolist(), moved.structure == problem.structure
        ([0.2, 1.0, 0.0], True)
        """
        new = self._copy()
        given = {"q_start": q_start, "q_goal": q_goal, "v_start": v_start, "v_goal": v_goal,
                 "p_start": p_start}
        set_boundary(new, {k: v for k, v in given.items() if v is not None})
        same_nlp = (new._velocity_rows == self._velocity_rows
                    and (new.p_start is None) == (self.p_start is None))
        new._transcription = self._transcription.with_bounds(new) if same_nlp else Transcription(new)
        return new

    def with_parameters(self, **values):
        """This problem with new values of some of its `parameters` (same names and sizes):
        the same NLP and `structure`, so `optimize` reuses the solver, and the optimum of
        this problem warm-starts the copy.

        Examples
        --------
        >>> import casadi as ca, dmoc
        >>> disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
        >>> problem = dmoc.OptimalControlProblem(
        ...     disc, 20, q_start=[0, 0, 0], q_goal=[0, 1, 0], parameters={"r": 1.0},
        ...     running_cost=lambda q, v, u, w: u[0] ** 2 + w["r"] * u[1] ** 2)
        >>> heavier = problem.with_parameters(r=10.0)
        >>> heavier.parameter_values["r"].tolist(), heavier.structure == problem.structure
        ([10.0], True)
        """
        new = self._copy()
        new._parameters = self._parameters.with_values(**values)
        new._transcription = self._transcription.with_bounds(new)
        return new

    def with_steps(self, steps):
        """This problem on N = `steps` steps over the same time: h = N_old h_old / N (a
        free final time keeps its range). The step residual, costs and path constraints
        take h as an input and are shared; the NLP is new (another `structure`): an optimum
        of this problem guesses it through its trajectory, resampled (`dmoc.drivers.accuracy`).
        Parameters given along the horizon are refused (`ProblemParameters.on_steps`).

        >>> import dmoc.problems
        >>> finer = dmoc.problems.knife_edge_parking(20).with_steps(40)
        >>> finer.steps, finer.disc.h
        (40, 0.1)
        """
        new = self._copy()
        new._steps = checks.positive_int("steps", steps)
        new._parameters = self._parameters.on_steps(new._steps)
        new._disc = self._disc.with_step(self._steps * self._disc.h / new._steps)
        if not self.free_time:
            new._final_time = FixedFinalTime(new._disc.h)
        new._transcription = Transcription(new)
        return new

    def with_rule(self, rule):
        """This problem with another `rule` of `dmoc.discretize`: a new NLP (`structure`)."""
        new = self._copy()
        new._disc = discretize(self._disc.system, self._disc.h, rule)
        new._formulation, new._residual, new._momentum_treatment, new._path = rule_parts(
            new._disc, self.variant, *self._stated, self._parameters)
        new._transcription = Transcription(new)
        return new
