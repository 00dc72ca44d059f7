"""Consumer 2 of the step residual, its problem half: OptimalControlProblem builds the DMOC
nonlinear program (Ober-Bloebaum, Junge & Marsden 2011) whose dynamic constraints are the
(+)/(-) step residual of (37)/(41), mapped over all steps with `Function.map`, with the
momentum boundary conditions of `boundary` and Delta_Q^d imposed directly.
"""

import copy

import casadi as ca
import numpy as np

from .._util import checks
from ..mechanics.given import check_allowed_velocity
from .boundary import check_holonomic_boundary
from ..discrete import Discretization
from ..principle.formulations import as_formulation
from ..principle.explicit import solved_rows, substitutable
from .._util.layout import Layout
from .parameters import ProblemParameters, cost_function, path_function
from ..principle.residual import step_residual
from .scaling import nlp_scales
from .transcription import transcribe
from ..errors import InputError


MOMENTA = ("substituted", "variables")


class OptimalControlProblem:
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
    running_cost : callable, optional
        ``running_cost(q, v, u)`` (scalar CasADi expression); default |u|^2. Discretized by
        the rule of `disc` at its quadrature points, u interpolated from the step's
        control values (midpoint: h C(q_{k+1/2}, (q_{k+1} - q_k)/h, u_k)). With
        `parameters`, it, `terminal_cost` and `path_constraints` take one more argument,
        ``w``: a dict of the parameters' symbols by name.
    terminal_cost : callable, optional
        ``terminal_cost(q, v)`` at (q_N, v_N).
    control_bounds, state_bounds : pair of array_like, optional
        (lower, upper), shapes (n_u,) and (n,); None entries are unbounded.
    path_constraints : callable, optional
        ``path_constraints(q, v, u) -> g`` imposed as g <= 0 at every step midpoint (on the
        rule's interpolant, u interpolated there).
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
        free of p_k) carries the momenta as variables (`dmoc._momentum.substitutable`).
    parameters : dict of str -> float or array_like of shape (k,), optional
        Named data the costs and path constraints read through ``w`` (weights, obstacle
        positions): entries of p, so `with_parameters` changes them without a new NLP.

    Attributes
    ----------
    nlp : dict
        ``{"x", "p", "f", "g"}`` CasADi MX expressions, for power users (``casadi.nlpsol``;
        pass ``p=problem.p``). Its x is the scaled vector x / `x_scale` and its g the
        scaled rows `g_scale` * g: pass ``x0 / x_scale``, ``lbx / x_scale``,
        ``ubx / x_scale``, ``lbg * g_scale``, ``ubg * g_scale`` and multiply the
        solution by `x_scale`.
    x_scale, g_scale : ndarray, shapes (x_layout.size,) and (g_layout.size,)
        The scaling by the system's inertia at `q_ref` (`dmoc.scaling`): momenta,
        controls and multipliers by the inertia they act on, the rows in momentum units by
        its inverse; all 1 for unit inertia. Kept by `with_boundary` and
        `with_parameters`.
    separable : SeparableNLP
        The same NLP as terms (`dmoc.separable`), with its assembled exact derivatives
        (``separable.derivatives()``, the ``cache`` option of ``casadi.nlpsol``).
    lbx, ubx, lbg, ubg : ndarray
        Bounds of x and g.
    p : ndarray, shape (p_layout.size,)
        The values of the NLP's parameter vector p: the step h (fixed final time), q_ref
        and the stacked `parameter_values` (block ``w``).
    q_ref : ndarray, shape (n,)
        The configuration the NLP is centered on: its block "q" holds q_k - q_ref (the
        given entries of q_start, else of q_goal, else 0), so that IPOPT's steps and
        tolerances follow the size of the motion, not of the coordinates;
        `configurations(x)` gives q.
    x_layout, p_layout, g_layout : Layout
        Named blocks of x (``q, p, lam, s, u, v_start, v_goal, mu, nu, h``; ``p`` is p_0
        alone when the momenta are substituted, see `momenta(x)`), of p (``h, q_ref, w``) and
        of g (``dynamics`` (rows of R in `dynamics_rows`, N), ``start``, ``goal``,
        ``start_velocity``, ``goal_velocity``, ``path``).
    dynamics_rows : Layout
        The residual rows imposed at each step (all of R, or all but "right").
    structure : str
        A key of the NLP by value; see `with_boundary` and `dmoc.optimize`.
    """

    def __init__(self, disc, steps, *, q_start, q_goal, v_start=None, v_goal=None,
                 running_cost=None, terminal_cost=None, control_bounds=None,
                 state_bounds=None, path_constraints=None, duration=None, variant="+",
                 momenta="substituted", parameters=None):
        checks.instance("disc", disc, Discretization, "a Discretization")
        self.disc, sys = disc, disc.system
        self.steps = N = checks.positive_int("steps", steps)
        self.formulation = as_formulation(variant, disc)
        self.residual = step_residual(disc, self.formulation)
        self.momenta_substituted = (checks.choice("momenta", momenta, MOMENTA) == "substituted"
                                    and substitutable(self.residual))
        n = sys.n
        self.duration = _duration(duration, N, disc.h)
        self._parameters = w = ProblemParameters(parameters)
        default = (lambda q, v, u, w: ca.sumsqr(u)) if w.given else (lambda q, v, u: ca.sumsqr(u))
        self._running = cost_function("running_cost", running_cost or default, sys, ("q", "v", "u"), w)
        self._terminal = None if terminal_cost is None else cost_function(
            "terminal_cost", terminal_cost, sys, ("q", "v"), w)
        self._path = None if path_constraints is None else path_function(path_constraints, disc, w)
        self._bound_data = (_bounds("control_bounds", control_bounds, sys.n_u),
                            _bounds("state_bounds", state_bounds, n))
        self._set_boundary(q_start, q_goal, v_start, v_goal)
        self._build()

    def _set_boundary(self, q_start, q_goal, v_start, v_goal):
        n, sys = self.disc.system.n, self.disc.system
        self.q_start = _boundary("q_start", q_start, n)
        self.q_goal = _boundary("q_goal", q_goal, n)
        self.v_start = _boundary("v_start", np.zeros(n) if v_start is None else v_start, n)
        self.v_goal = _boundary("v_goal", np.zeros(n) if v_goal is None else v_goal, n)
        check_holonomic_boundary(sys, self.q_start, self.q_goal)
        for end in ("start", "goal"):
            if self._fully_given(end):
                check_allowed_velocity("v_" + end, sys, getattr(self, "q_" + end),
                                       getattr(self, "v_" + end))

    def with_boundary(self, *, q_start=None, q_goal=None, v_start=None, v_goal=None):
        """This problem with new boundary data; arguments left None keep this problem's.

        The boundary data enter the NLP only through the bounds lbx = ubx, so the copy
        shares this problem's NLP (and `structure`, hence its compiled solver and a warm
        start from this problem's optimum) unless an end changes between fully given and
        partly free with a nonzero or free velocity (then the velocity rows A(q) v = 0
        appear or vanish and the NLP is rebuilt).

        Examples
        --------
        >>> import dmoc, dmoc.problems
        >>> problem = dmoc.problems.knife_edge_parking(20)
        >>> moved = problem.with_boundary(q_goal=[0.2, 1.0, 0.0])
        >>> moved.q_goal.tolist(), moved.structure == problem.structure
        ([0.2, 1.0, 0.0], True)
        """
        new = copy.copy(self)
        given = {"q_start": q_start, "q_goal": q_goal, "v_start": v_start, "v_goal": v_goal}
        kept = {k: [None if np.isnan(x) else x for x in getattr(self, k)] for k in given}
        new._set_boundary(**{k: kept[k] if v is None else v for k, v in given.items()})
        if all(new._velocity_rows(e) == self._velocity_rows(e) for e in ("start", "goal")):
            new._set_bounds()
        else:
            new._build()
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
        new = copy.copy(self)
        new._parameters = self._parameters.with_values(**values)
        new._set_bounds()
        return new

    @property
    def parameter_values(self):
        """{name: value, shape (k,)} of the problem's `parameters`."""
        return {k: v.copy() for k, v in self._parameters.values.items()}

    @property
    def structure(self):
        """A key of the NLP by value (`SeparableNLP.key`: its terms' Functions and index
        arrays): problems with equal keys differ at most in lbx, ubx, lbg, ubg and the
        parameters, so `optimize` reuses one compiled solver for them and warm-starts one
        from the other's optimum."""
        return self.separable.key

    def _fully_given(self, end):
        """True when q and v at `end` ("start" or "goal") have no free entries."""
        return bool(np.isfinite(getattr(self, "q_" + end)).all()
                    and np.isfinite(getattr(self, "v_" + end)).all())

    def _velocity_rows(self, end):
        """Whether A(q) v = 0 is imposed at `end`: unless q and v are given there (then
        checked once, `check_allowed_velocity`) or v is given and zero (then the rows
        vanish for every q; imposing them would make the KKT matrix singular)."""
        v = getattr(self, "v_" + end)
        return not (self._fully_given(end) or (np.isfinite(v).all() and not v.any()))

    @property
    def variant(self):
        """The formulation's name, ``"+"`` or ``"-"``."""
        return self.formulation.name

    @property
    def free_time(self):
        """True when the final time is a decision variable."""
        return self.duration is not None

    def _build(self):
        sys, disc, N, R = self.disc.system, self.disc, self.steps, self.residual
        n, ns = sys.n, disc.n_stages
        m_start, m_end = self.formulation.momentum_conditions(sys)[2:]
        path = self._path
        velocity_rows = {e: sys.m if self._velocity_rows(e) else 0 for e in ("start", "goal")}
        substituted = self.momenta_substituted
        self.dynamics_rows = solved_rows(R) if substituted else R.row_layout
        self.x_layout = Layout([("q", (n, N + 1)), ("p", (n, 1 if substituted else N + 1)),
                                ("lam", (disc.n_multipliers, N)),
                                ("s", (ns, N)), ("u", (disc.n_controls, N)), ("v_start", (n, 1)),
                                ("v_goal", (n, 1)), ("mu", (m_start, 1)), ("nu", (m_end, 1)),
                                ("h", (1 if self.free_time else 0, 1))])
        self.p_layout = Layout([("h", (0 if self.free_time else 1, 1)), ("q_ref", (n, 1)),
                                ("w", (self._parameters.layout.size, 1))])
        self.g_layout = Layout([("dynamics", (self.dynamics_rows.size, N)), ("start", (n, 1)), ("goal", (n, 1)),
                                ("start_velocity", (velocity_rows["start"], 1)),
                                ("goal_velocity", (velocity_rows["goal"], 1)),
                                ("path", (path.numel_out(0) if path else 0, N))])
        self.x_scale, self.g_scale = nlp_scales(self, _reference(self.q_start, self.q_goal))
        self.separable, self._momenta = transcribe(self)
        self.nlp = {k: getattr(self.separable, k) for k in ("x", "p", "f", "g")}
        self._set_bounds()

    def momenta(self, x):
        """The momenta p_0 ... p_N, shape (N+1, n), of an NLP vector x (their block "p" when
        they are variables, computed from x when substituted)."""
        return self._momenta(np.asarray(x, dtype=float), self.p).T

    def configurations(self, x):
        """The configurations q_0 ... q_N, shape (N+1, n), of an NLP vector x (whose block
        "q" holds q - q_ref)."""
        return self.x_layout.unpack(np.asarray(x, dtype=float), "q").T + self.q_ref

    def _set_bounds(self):
        control_bounds, state_bounds = self._bound_data
        for name in ("q_start", "q_goal"):
            data = getattr(self, name)
            outside = np.isfinite(data) & ((data < state_bounds[0]) | (data > state_bounds[1]))
            if outside.any():
                raise InputError(f"`{name}` must lie within `state_bounds`; entries "
                                 f"{np.flatnonzero(outside).tolist()} do not.")
        N, lay = self.steps, self.x_layout
        self.q_ref = _reference(self.q_start, self.q_goal)
        self.p = np.concatenate([[] if self.free_time else [self.disc.h], self.q_ref,
                                          self._parameters.vector()])
        self.lbx, self.ubx = np.full(lay.size, -np.inf), np.full(lay.size, np.inf)
        for bound, side in ((self.lbx, 0), (self.ubx, 1)):
            view = {name: self.x_layout.unpack(bound, name) for name in ("q", "u", "v_start", "v_goal", "h")}
            view["q"][:] = (state_bounds[side] - self.q_ref)[:, None]
            view["u"][:] = np.tile(control_bounds[side], len(self.disc.rule.control_nodes))[:, None]
            for name, col, data in (("q", 0, self.q_start - self.q_ref), ("q", N, self.q_goal - self.q_ref),
                                    ("v_start", 0, self.v_start), ("v_goal", 0, self.v_goal)):
                fixed = np.isfinite(data)
                view[name][fixed, col] = data[fixed]
            if self.free_time:
                view["h"][:] = self.duration[side] / N
        self.lbg, self.ubg = np.zeros(self.g_layout.size), np.zeros(self.g_layout.size)
        self.lbg[self.g_layout.slice("path")] = -np.inf

    def __repr__(self):
        return (f"OptimalControlProblem(steps={self.steps}, variant={self.variant!r}, "
                f"free_time={self.free_time}, x: {self.x_layout.size}, g: {self.g_layout.size})")


def _reference(q_start, q_goal):
    """q_ref, shape (n,): the given entries of q_start, else of q_goal, else 0. The NLP's
    configuration variables are q - q_ref, of the size of the motion rather than of the
    coordinates, so that IPOPT's steps and tolerances do not depend on where the motion
    takes place (e.g. map coordinates of 1e6 m)."""
    return np.where(np.isfinite(q_start), q_start, np.nan_to_num(q_goal, nan=0.0))


def _boundary(name, value, n):
    """Boundary data of shape (n,) with None entries as NaN (free); never infinite."""
    if value is None:
        raise InputError(f"`{name}` is required: an array of shape ({n},), None entries free.")
    if np.ndim(value) == 0:
        raise InputError(f"`{name}` must have shape ({n},) for this system; got ().")
    return checks.array(name, checks.array_with_none(name, value, n, np.nan), (n,), allow_nan=True)


def _bounds(name, value, size):
    """(lower, upper) arrays of shape (size,) with None entries unbounded."""
    if value is None:
        return np.full(size, -np.inf), np.full(size, np.inf)
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise InputError(f"`{name}` must be a pair (lower, upper) of arrays of shape ({size},).")
    lower = checks.array_with_none(name, value[0], size, -np.inf)
    upper = checks.array_with_none(name, value[1], size, np.inf)
    if np.isnan(lower).any() or np.isnan(upper).any() or (lower > upper).any():
        raise InputError(f"`{name}` must satisfy lower <= upper without NaN; got {lower}, {upper}.")
    if (lower == np.inf).any() or (upper == -np.inf).any():
        raise InputError(f"`{name}` must have lower bounds below +inf and upper bounds above "
                         f"-inf (None or -inf/+inf there means unbounded); got {lower}, {upper}.")
    return lower, upper


def _duration(duration, N, h):
    if duration is None:
        return None
    if not isinstance(duration, (tuple, list)) or len(duration) != 2:
        raise InputError(f"`duration` must be None (fixed, steps * h = {N * h:g}) or a pair "
                         f"(T_min, T_max) for a free final time; got {duration!r}.")
    T_min, T_max = (checks.positive_float("duration", T) for T in duration)
    if T_min > T_max:
        raise InputError(f"`duration` must have T_min <= T_max; got {duration!r}.")
    return T_min, T_max
