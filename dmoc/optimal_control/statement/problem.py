"""Consumer 2 of the step residual, its statement: OptimalControlProblem holds the user's
DMOC problem (Ober-Bloebaum, Junge & Marsden 2011), the discretization, the boundary data
(set and checked by `boundary`), the costs, bounds and parameters, with the step residual of
(37)/(41) that is imposed at every step, the final time and the momentum treatment chosen
once as values. Its `transcription` (`dmoc.optimal_control.nlp.transcription`) is the NLP built
from it, once.
"""

import casadi as ca
import numpy as np

from ..._util import checks
from ...discrete import Discretization
from .boundary import set_boundary
from .final_time import as_final_time
from .parameters import ProblemParameters, cost_function
from .problem_copies import ProblemCopies
from .rule_parts import rule_parts
from .read_only import ReadOnly, Transcribed, frozen
from ..nlp.transcription import Transcription


class OptimalControlProblem(ProblemCopies, ReadOnly):
    """A DMOC problem: minimize sum_k C_d(q_k, q_{k+1}, u_k) + terminal cost subject to the
    step residual of (37)/(41) at every step and the boundary data.

    Parameters
    ----------
    disc : Discretization
        Its step h fixes the duration steps * h, unless `duration` frees it.
    steps : int
        Number of steps N.
    q_start, q_goal : array_like, shape (n,)
        Boundary configurations; entries None leave that component free.
    v_start, v_goal : array_like, shape (n,), optional
        Boundary velocities (default: at rest); entries None are free. They must lie in
        Delta_Q = ker A(q) when fully given; otherwise A(q) v = 0 is imposed (except for
        a given zero velocity, which lies in every Delta_Q).
    p_start : array_like, shape (n,), optional
        A start momentum instead of `v_start` (exclusive), as a receding-horizon
        controller measures it: the start rows become p_0 = p_start (+ form; p_0 =
        p_start - A(q_0)^T mu for the (-) form) in place of p_0 = dL/dv(q_0, v_start), and
        no velocity rows are imposed at the start. Fully given; a value of the NLP's
        parameter vector, so `with_boundary` changes it without a new NLP.
    running_cost : callable, optional
        ``running_cost(q, v, u)`` (scalar CasADi expression); default |u|^2. Discretized by
        the rule of `disc` at its quadrature points, u interpolated from the step's
        control values (midpoint: h C(q_{k+1/2}, (q_{k+1} - q_k)/h, u_k)). With
        `parameters`, it, `terminal_cost` and `path_constraints` take one more argument,
        ``w``: a dict of the parameters' symbols by name.
    terminal_cost : callable, optional
        ``terminal_cost(q, v)`` at (q_N, v_N).
    control_bounds, state_bounds : pair of array_like, optional
        (lower, upper), shapes (n_u,) and (n,); None entries are unbounded. Imposed on x:
        the controls at the rule's control nodes, the configurations at the knots.
    velocity_bounds : pair of array_like, optional
        (lower, upper), shape (n,) each, None entries unbounded: lower <= v <= upper on the
        velocity of the rule's interpolant at every knot (the knot velocity below) and at
        each step's interior points (a stage rule's stage nodes, a linear rule's midpoint),
        and on free boundary velocities; a given `v_start` or `v_goal` outside them is
        refused. A rate limit (|steering rate| <= 0.4) is one of these.
    path_constraints : callable, optional
        ``path_constraints(q, v, u) -> g`` imposed as g <= 0 at each step's interior points
        (on the rule's interpolant, u and w interpolated there) and at every knot q_0 ...
        q_N with the knot velocity and the knot's control and w; a given end that violates a row of q
        alone is refused (docs/stages/optimize.md, "Path constraints and velocity
        bounds").
    duration : pair of float, optional
        (T_min, T_max): free final time, h = T/N becomes a decision variable.
    variant : {"+", "-"} or Formulation
        The form of the step equations and of the momentum boundary rows
        (`dmoc.formulations`).
    momenta : {"substituted", "variables"}
        "substituted" (default): only p_0 is a variable; p_{k+1} = D2 L_d + f_d^+ (- A^T lam
        for (-)) follows from step k's explicit "right" rows, which then hold by
        construction, and the other rows are imposed (a smaller NLP: n fewer variables
        and rows per step). "variables": every p_k a variable and all rows imposed. A
        formulation whose p_{k+1} is not explicit (the Hamiltonian (+) form (39), explicit
        in q_{k+1}) or depends on p_k (the (-) form (43), unless the Hamiltonian makes it
        free of p_k) carries the momenta as variables (`dmoc.principle.explicit.substitutable`).
    parameters : dict of str -> float or array_like, optional
        Named data the costs and path constraints read through ``w`` (weights, obstacles,
        references): entries of p, so `with_parameters` changes them without a new NLP.
        Shape (k,) fixed, (N, k) per step, (N+1, k) per knot; ``"t"`` the clock
        (`ProblemParameters`).

    Attributes
    ----------
    disc, steps, formulation, residual : Discretization, int, Formulation, StepResidual
        The discretization, N, the form of the step rows and the residual they impose.
    q_start, q_goal, v_start, v_goal : ndarray, shape (n,)
        The boundary data, NaN where free (read-only arrays; `with_boundary` changes them);
        `v_start` is all NaN when `p_start` is given.
    p_start : ndarray, shape (n,), or None
        The start momentum, when given instead of `v_start`.
    control_bounds, state_bounds, velocity_bounds : tuple of ndarray
        (lower, upper), shapes (n_u,), (n,) and (n,), infinite where unbounded.
    velocity_bounded : tuple of int
        The entries of v with a finite velocity bound (the velocity rows' entries).
    running_cost, terminal_cost, path_constraints : casadi.Function or None
        The user's callables checked on symbols: ``(q, v, u, w) -> cost``,
        ``(q, v, w) -> cost`` and ``(q, v, u, w) -> g``, the path constraints at one
        state (flattened to a column).
    parameters : ProblemParameters
        Their `parameter_values` are entries of p (`with_parameters` changes them).
    final_time : FixedFinalTime or FreeFinalTime
        Where h lives (p or x) and its range (`dmoc.optimal_control.statement.final_time`); `free_time`
        and `duration` read it.
    momentum_treatment : CarriedMomenta or SubstitutedMomenta
        How p_0 ... p_N enter the NLP (`dmoc.optimal_control.nlp.momenta`): the `momenta` choice, or
        carried where the formulation does not allow substitution.
    velocity_rows : dict
        {"start": bool, "goal": bool}: where A(q) v = 0 is imposed.
    transcription : Transcription
        The NLP of this problem: layouts, scales, terms, bounds and p. Its attributes
        ``nlp, separable, x_layout, p_layout, g_layout, dynamics_rows, x_scale, g_scale,
        lbx, ubx, lbg, ubg, p, q_ref, structure`` and methods ``momenta(x)``,
        ``configurations(x)`` are also the problem's (``problem.nlp is
        problem.transcription.nlp``). `structure` is a key of the NLP by value: see
        `with_boundary` and `dmoc.optimize`.

    Notes
    -----
    Where each limit is imposed (every row of the NLP is named in
    `Transcription.g_layout`; `dmoc.optimal_control.nlp.path_terms`):

    ======================  ===============================================================
    control_bounds          the control values u_{k,j} at the rule's control nodes (x),
                            and, for 3 or more nodes, the interior Bernstein coefficients
                            of their interpolant, so it stays in the box (g)
    state_bounds            the configurations q_0 ... q_N (x)
    velocity_bounds         the knot velocities v_0 ... v_N (stage rules; for a linear rule
                            they lie between two bounded step velocities) and the
                            interpolant's velocity at each step's interior points: the
                            stage nodes, the midpoint of a linear rule (g); the free
                            entries of v_start, v_goal (x)
    path_constraints        every row at each step's interior points t_k + c h (as the
                            velocity bounds), (q, q', u, w) there on the interpolant, w the
                            parameters at c, and every row at every knot, (q_k, v_k, u(t_k),
                            w(t_k)) (g)
    ======================  ===============================================================

    The knot velocity v_k is the mean of the velocities of the interpolants of steps k - 1
    and k at q_k (one side at q_0 and q_N), and u(t_k) the control of the step that starts
    at t_k (the last step's at t_N), as `Trajectory.control` gives it:
    `dmoc.discrete.knot_states`, the one definition the verdict checks an optimum with
    (`dmoc.drivers.verdict`), so that the optimizer and the verdict read the same numbers.

    Every attribute is read-only: assigning one raises AttributeError naming the way to
    change it (`with_boundary`, `with_parameters`, or a new problem), so that the
    statement and its NLP never disagree.
    """

    _CHANGE = {**{k: f"use `problem.with_boundary({k}=...)`, which keeps the NLP"
                  for k in ("q_start", "q_goal", "v_start", "v_goal", "p_start")},
               **{k: "use `problem.with_parameters(name=value)`, which keeps the NLP"
                  for k in ("parameters", "parameter_values")}}
    _CHANGE_ANY = "build a new OptimalControlProblem (its data and its NLP are built together)"

    def __init__(self, disc, steps, *, q_start, q_goal, v_start=None, v_goal=None, p_start=None,
                 running_cost=None, terminal_cost=None, control_bounds=None,
                 state_bounds=None, velocity_bounds=None, path_constraints=None, duration=None,
                 variant="+", momenta="substituted", parameters=None):
        checks.instance("disc", disc, Discretization, "a Discretization")
        sys, self._steps = disc.system, checks.positive_int("steps", steps)
        self._final_time = as_final_time(duration, self._steps, disc.h)
        self._parameters = w = ProblemParameters(parameters, self._steps)
        self._stated = (momenta, path_constraints)      # `with_rule` makes the rule's parts anew
        self._disc, (self._formulation, self._residual, self._momentum_treatment, self._path) = \
            disc, rule_parts(disc, variant, momenta, path_constraints, w)
        default = (lambda q, v, u, w: ca.sumsqr(u)) if w.given else (lambda q, v, u: ca.sumsqr(u))
        self._running = cost_function("running_cost", running_cost or default, sys, ("q", "v", "u"), w)
        self._terminal = None if terminal_cost is None else cost_function(
            "terminal_cost", terminal_cost, sys, ("q", "v"), w)
        self._control_bounds = checks.bound_pair("control_bounds", control_bounds, sys.n_u)
        self._state_bounds = checks.bound_pair("state_bounds", state_bounds, sys.n)
        self._velocity_bounds = checks.bound_pair("velocity_bounds", velocity_bounds, sys.n)
        for bound in (*self._control_bounds, *self._state_bounds, *self._velocity_bounds):
            frozen(bound)
        set_boundary(self, {"q_start": q_start, "q_goal": q_goal, "v_start": v_start,
                            "p_start": p_start, "v_goal": np.zeros(sys.n) if v_goal is None else v_goal})
        self._transcription = Transcription(self)

    disc = property(lambda self: self._disc, doc="The Discretization (system, rule, step h).")
    steps = property(lambda self: self._steps, doc="The number of steps N.")
    formulation = property(lambda self: self._formulation, doc="The Formulation of the step rows.")
    residual = property(lambda self: self._residual, doc="The StepResidual imposed at every step.")
    momentum_treatment = property(lambda self: self._momentum_treatment,
                                  doc="CarriedMomenta or SubstitutedMomenta (`dmoc.optimal_control.nlp.momenta`).")
    final_time = property(lambda self: self._final_time,
                          doc="FixedFinalTime or FreeFinalTime (`dmoc.optimal_control.statement.final_time`).")
    q_start = property(lambda self: self._q_start, doc="Start configuration, shape (n,), NaN free.")
    q_goal = property(lambda self: self._q_goal, doc="Goal configuration, shape (n,), NaN free.")
    v_start = property(lambda self: self._v_start, doc="Start velocity, shape (n,), NaN free.")
    p_start = property(lambda self: self._p_start, doc="Start momentum, shape (n,), or None.")
    v_goal = property(lambda self: self._v_goal, doc="Goal velocity, shape (n,), NaN free.")
    control_bounds = property(lambda self: self._control_bounds, doc="(lower, upper), shapes (n_u,).")
    state_bounds = property(lambda self: self._state_bounds, doc="(lower, upper), shapes (n,).")
    velocity_bounds = property(lambda self: self._velocity_bounds, doc="(lower, upper), shapes (n,).")
    parameters = property(lambda self: self._parameters, doc="The ProblemParameters.")
    running_cost = property(lambda self: self._running, doc="Function (q, v, u, w) -> cost.")
    terminal_cost = property(lambda self: self._terminal, doc="Function (q, v, w) -> cost, or None.")
    path_constraints = property(lambda self: self._path,
                                doc="Function (q, v, u, w) -> g (g <= 0), or None.")
    transcription = property(lambda self: self._transcription, doc="The problem's Transcription.")

    nlp = Transcribed()
    separable = Transcribed()
    x_layout = Transcribed()
    p_layout = Transcribed()
    g_layout = Transcribed()
    dynamics_rows = Transcribed()
    x_scale = Transcribed()
    g_scale = Transcribed()
    lbx = Transcribed()
    ubx = Transcribed()
    lbg = Transcribed()
    ubg = Transcribed()
    p = Transcribed()
    q_ref = Transcribed()
    structure = Transcribed()
    momenta = Transcribed()
    configurations = Transcribed()

    parameter_values = property(lambda self: {k: v.copy() for k, v in self._parameters.values.items()},
                                doc="{name: value, shape (k,), (N, k) or (N+1, k)} of the `parameters`.")

    @property
    def velocity_rows(self):
        """{"start": bool, "goal": bool}: whether A(q) v = 0 is imposed at that end
        (`dmoc.optimal_control.statement.boundary.imposes_velocity_rows`), found when the boundary data are
        set."""
        return dict(self._velocity_rows)

    @property
    def velocity_bounded(self):
        """The entries of v with a finite velocity bound, a tuple of int: those of the
        NLP's velocity rows."""
        lower, upper = self._velocity_bounds
        return tuple(int(i) for i in np.flatnonzero(np.isfinite(lower) | np.isfinite(upper)))

    @property
    def variant(self):
        """The formulation's name, ``"+"`` or ``"-"``."""
        return self._formulation.name

    @property
    def free_time(self):
        """True when the final time is a decision variable (`final_time.free`)."""
        return self._final_time.free

    @property
    def duration(self):
        """(T_min, T_max) of a free final time, else None."""
        return self._final_time.duration

    def __repr__(self):
        T = self._transcription
        return (f"OptimalControlProblem(steps={self.steps}, variant={self.variant!r}, "
                f"free_time={self.free_time}, x: {T.x_layout.size}, g: {T.g_layout.size})")
