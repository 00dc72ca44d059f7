"""Model predictive control on the DMOC NLP (a driver: the optimizer in a closed loop): a
receding-horizon controller re-solves one problem structure from each measured state, made
a start within the bounds and on the constraints by its measurement policy
(`dmoc.drivers.measurement`) and given by a momentum (`OptimalControlProblem(p_start=...)`),
with the windows of its references and its clock moved on by one step
(`dmoc.drivers.references`; new parameter values, the same NLP), with IPOPT's kept solver
warm-started from the previous optimum shifted by one step, primal and dual, and applies
the first step's controls; a failed solve raises, or (``on_failure="shift"``) the last
optimum's plan is followed one more step.
"""

import time

import numpy as np

from .._util import checks
from ..errors import InputError, Status, failure
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from ..optimal_control.statement.problem import OptimalControlProblem
from ..optimal_control.solver.solving import solve        # the raw IPOPT solve of one problem
from .group_horizon import GroupHorizon
from .horizon_shift import shifted
from .measurement import MeasurementPolicy
from .mpc_step import MPCStep
from .references import HorizonReferences

ON_FAILURE = ("raise", "shift")


class MPC:
    """A receding-horizon controller: at each measured state (q, v) or (q, p), the optimum
    of `problem` from there over its N steps; the first step's controls are applied.

    Parameters
    ----------
    problem : OptimalControlProblem or GroupOptimalControlProblem
        The horizon (N steps of h), goal, costs and bounds; its start data are replaced by
        each measurement (as a start momentum: the problem is restated once with
        ``with_boundary(p_start=...)``, so every step solves the same NLP structure). A
        problem on SO(3) x R^n_x (`dmoc.drivers.group_horizon.GroupHorizon`) has its
        NLP built once, its start (R_0, x_0, p_0) fixed by the bounds of each step; it
        takes no `guess`, `references`, `parameters` or ``jit=True`` (`expand` and
        ``jit=None`` act as on R^n).
    guess : Trajectory or OptimizationResult, optional
        The first solve's guess (`optimize`); later solves start from the previous
        optimum shifted by one step.
    options : dict, optional
        IPOPT options (`optimize`).
    expand, jit : bool
        How IPOPT evaluates the NLP in every solve, as `optimize`'s switches of the same
        names (docs/stages/optimize.md, "Compiled re-solves"): flat SX Functions, or C
        compiled once per structure (or loaded from the compiled-code cache) when the
        first step builds the solver; either way the same iterations and bits as the
        MX graph (``expand=False, jit=False``). `expand` is True by default, unlike
        `optimize`'s: a controller builds its solver once and solves on it at every step,
        so the expansion's cost (a few ms at step 0) buys a cheaper evaluation at every
        warm step (benchmarks/mpc.py --mx). `jit` None (default), as `optimize`'s: after
        0.1 s of warm steps the structure is compiled in the background, the steps after
        it is loaded evaluate it (the same bits). With `jit`, `expand` has no effect.
    on_failure : {"raise", "shift"}
        What a step does when IPOPT does not converge. "raise" (default): raise
        SolverError (the failed solve in `.result`); no control is returned. "shift":
        return the controls of the last optimum's plan at the step that follows it (the
        plan moved on by one step per failed solve, which the model can follow from the
        plan's own states), and raise SolverError only when no plan is left: the first
        solve failed, or N solves in a row. Either way the step is recorded in `log`.
        A Ctrl-C during a solve raises Interrupted.
    measurement : {"project", "refuse"}
        What a step does with a measured state outside `state_bounds` or off the
        constraints (g(q) = 0, A(q) v = 0), as sensor noise makes it
        (`dmoc.drivers.measurement.MeasurementPolicy`). "project" (default): the closest
        start within the box and on the constraints, in the metric of the mass matrix
        d2L/dv2 (q clipped to the box and put on g = 0, v projected onto ker A(q)); the
        record says what was corrected and by how much. "refuse": InputError naming the
        step and each violated bound or constraint with its value. On the group
        (`dmoc.drivers.group_measurement.GroupMeasurementPolicy`) a measured R off SO(3)
        is replaced by the nearest rotation (the polar factor), recorded as "rotation".
    references : dict of str -> array_like of shape (M, k), optional
        For a tracking controller: the whole run's values of parameters of `problem` given
        per step or per knot (a planned trajectory, its controls as a feed-forward); step j
        solves with their rows j ... j+N-1 (per step) or j ... j+N (per knot), the last
        row repeated past the end (`dmoc.drivers.references.HorizonReferences`). With the
        clock (the parameter ``"t"``), step j also starts at the time t_0 plus the steps h
        applied so far.

    Attributes
    ----------
    on_failure, measurement : str
        The `on_failure` and `measurement` policies.
    problem : OptimalControlProblem or GroupOptimalControlProblem
        The problem of the last step (its start the last measurement; on the group the
        problem as given, its start in the NLP's bounds).
    plan : OptimizationResult or None
        The last optimum over the horizon (of the last step whose solve succeeded).
    log : list of MPCStep
        One record per step.

    Notes
    -----
    The warm start is the previous optimum moved one step on: every block of x, of its
    bound multipliers and of the constraint multipliers indexed by step (q_k, p_k, lam_k,
    s_k, u_k and the dynamics and path rows of step k) takes the value of step k + 1, the
    last step's repeated; the boundary blocks keep theirs. IPOPT starts from it with
    ``warm_start_init_point`` (x clipped into the new bounds: q_0 is the measurement).
    After k failed solves in a row (``on_failure="shift"``) it is the last optimum moved
    k + 1 steps on. On the group the rotations move along the plan's own increments and
    the plan is carried onto the measured start (`dmoc.drivers.horizon_shift.shifted_on_group`).

    Examples
    --------
    >>> import dmoc
    >>> controller = MPC(dmoc.problems.knife_edge_parking(20))
    >>> u = controller.step([0.0, 0.0, 0.0], v=[0.0, 0.0, 0.0])
    >>> u.shape, controller.log[-1].success
    ((2,), True)
    """

    def __init__(self, problem, *, guess=None, options=None, on_failure="raise",
                 measurement="project", references=None, expand=True, jit=None):
        checks.instance("problem", problem, (OptimalControlProblem, GroupOptimalControlProblem),
                        "an OptimalControlProblem or a GroupOptimalControlProblem")
        self.on_failure = checks.choice("on_failure", on_failure, ON_FAILURE)
        switches = {"expand": checks.boolean("expand", expand),
                    "jit": None if jit is None else checks.boolean("jit", jit)}
        kind = GroupHorizon if isinstance(problem, GroupOptimalControlProblem) else VectorHorizon
        self._horizon = kind(problem, guess, options, measurement, references, switches)
        self.measurement = self._horizon.measurement.policy
        self.plan, self.log, self._age = None, [], 0

    @property
    def problem(self):
        """The problem of the last step (its start the last measurement)."""
        return self._horizon.problem

    def step(self, q, *, v=None, p=None, parameters=None):
        """Solve from the measured state and return the controls of the first step.

        Parameters
        ----------
        q : array_like, shape (n,)
            On SO(3) x R^n_x: the rotation R (3, 3), or the pair (R, x), x shape (n_x,).
        v, p : array_like, shape (n,)
            The measured velocity (then p = dL/dv(q, v)) or momentum: exactly one; on the
            group (Omega, x') or (Pi, p_x), shape (3 + n_x,). A measurement outside
            `state_bounds` or off the constraints (or, on the group, R off SO(3)) is
            projected or refused by the `measurement` policy.
        parameters : dict, optional
            New values of the problem's parameters from this step on
            (`OptimalControlProblem.with_parameters`: the same NLP), e.g. a reference
            window of your own; names in `references` and the clock are the
            controller's. Not on the group (it has no parameters).

        Returns
        -------
        ndarray, shape (len(control_nodes) * n_u,)
            The first step's controls at the rule's control nodes (node by node), to apply
            over one step h (``simulate(..., controls=u[None])``; with a free final time h
            is the plan's, `MPCStep.h`); after a failed solve with
            ``on_failure="shift"``, those of the last optimum's plan at the step that follows.

        Raises
        ------
        InputError
            A measurement of the wrong shape or with a NaN or infinite entry, neither or
            both of v and p, or (``measurement="refuse"``) one outside the box or off the
            constraints; the message names the step and the entry. Nothing is recorded.
        SolverError
            IPOPT did not converge and `on_failure` is "raise", or no plan is left to
            follow; its `.result` holds the last iterate.
        Interrupted
            A Ctrl-C stopped IPOPT.
        """
        tic, k = time.perf_counter(), len(self.log)
        start = self._horizon.measurement.start(k, q, v=v, p=p)
        self._horizon.restate(k, start, parameters)
        result = self._horizon.solve(self.plan, self._age + 1, start)
        if result.success:
            self.plan, self._age = result, 0
        elif result.status != Status.INTERRUPTED and self.on_failure == "shift" and self.plan is not None \
                and self._age + 1 < self.problem.steps:
            self._age += 1
        else:
            self._record(start, None, result, tic, None)
            raise self._failure(result)
        u = self._horizon.controls(self.plan, self._age)
        self._record(start, u, result, tic, self._age)
        self._horizon.advance(self.log[-1].h)
        return u

    def _record(self, start, u, result, tic, age):
        h = None if age is None else self._horizon.step_length(self.plan)
        self.log.append(MPCStep(
            start.q, start.p, u, result.success, result.status, result.stats["iterations"],
            result.stats["solve_time"], time.perf_counter() - tic, result.stats["warm_start"],
            age, h, self.measurement, start.corrected, start.q_measured, start.v_measured,
            start.p_measured, start.q_correction, start.v_correction))

    def _failure(self, result):
        """The error of a failed step: Interrupted for a Ctrl-C, else SolverError saying
        why no control is returned."""
        step = len(self.log) - 1
        if result.status == Status.INTERRUPTED:
            return failure(f"MPC step {step}: {result.message}", result)
        why = ("on_failure='raise'" if self.on_failure == "raise" else
               "no plan to follow: the first solve failed" if self.plan is None else
               f"the last optimum's plan is used up ({self._age + 1} failed solves in a row)")
        return failure(f"MPC step {step}: {result.message} No control is applied ({why}); "
                       f"the last iterate is in `.result`.", result)


class VectorHorizon:
    """What `MPC` solves on R^n: `problem` restated from each start (its start momentum
    given, so that every step solves the same NLP structure), its references' windows and
    clock, the solve (`optimize` unjudged, warm from the shifted plan) and the plan's
    controls; the arguments are `MPC`'s."""

    def __init__(self, problem, guess, options, measurement, references, switches):
        self.measurement = MeasurementPolicy(problem, measurement)
        if not np.isfinite(problem.q_start).all():
            raise InputError("`problem` must have a fully given `q_start`: the controller's "
                             "measurements replace it, and the NLP keeps its structure.")
        start = problem.p_start if problem.p_start is not None else np.zeros(problem.disc.system.n)
        self.problem = problem.with_boundary(p_start=start)
        self._references = HorizonReferences(problem, references)
        self._guess, self._options, self._switches = guess, options, switches

    def restate(self, step, start, parameters):
        """The problem of step `step`: the start, and the parameters (the windows of the
        references, the clock, the caller's `parameters`) where any are to be set."""
        try:
            values = dict(parameters or {})
            mine = sorted(self._references.names & set(values))
            if mine:
                raise InputError(f"`parameters` must not set {mine}: the controller moves its "
                                 f"references and its clock on by itself.")
            values.update(self._references.at(step))
            problem = self.problem.with_parameters(**values) if values else self.problem
            self.problem = problem.with_boundary(q_start=start.q, p_start=start.p)
        except InputError as err:       # e.g. a start in an obstacle (path constraints)
            raise type(err)(f"MPC step {step}: {err}") from None

    def solve(self, plan, by, start):
        """The solve from the guess, or from `plan` moved `by` steps on."""
        guess = self._guess if plan is None else shifted(plan, self.problem, by)
        return solve(self.problem, guess=guess, options=self._options, throw=False, **self._switches)

    def controls(self, plan, age):
        """The controls of `plan` at its step `age`, read from x (the plan's Trajectory is
        made only when a caller asks for it)."""
        return self.problem.transcription.x_layout.unpack(plan.x, "u")[:, age].copy()

    def step_length(self, plan):
        """The step h of `plan` (its own with a free final time)."""
        return self.problem.final_time.step(self.problem.transcription.x_layout, plan.x)

    def advance(self, h):
        """The references' clock moved on by the applied step h."""
        self._references.advance(h)
