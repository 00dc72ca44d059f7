"""The user's data of a DMOC problem that are solver inputs, not part of the NLP: named
parameters w (cost weights, obstacle positions, reference paths) that the running cost,
the terminal cost and the path constraints read, and the Functions built from those user
callables. Problems that differ only in the values of w share one NLP and one solver.
"""

import inspect

import casadi as ca
import numpy as np

from ..._util import checks
from ..._util.symbolic import checked_function
from ...errors import InputError, InputTypeError
from ..solver.ipopt import DEFAULT_IPOPT_OPTIONS
from .parameter_schedule import CLOCK, FIXED, ParameterSchedule


class ProblemParameters:
    """Named parameters: fixed values, or values along the horizon (per step or per knot),
    and the clock.

    Parameters
    ----------
    values : dict of str -> float or array_like, or None
        Each a scalar or shape (k,) (fixed), (N, k) (one row per step, held over the step)
        or (N+1, k) (one row per knot, linear in time between knots); ``"t"``, a scalar,
        declares the clock: the callables' ``w["t"]`` is the time t_0 + (k + c) h where
        they are evaluated, its value the start time t_0
        (`dmoc.optimal_control.statement.parameter_schedule`). None (or an empty dict): no
        parameters, and the user callables take no `w`.
    steps : int
        N.

    Attributes
    ----------
    layout : Layout
        The blocks of the vector w the callables read, one per name (a scalar is a block
        of size 1): the values at the point where they are evaluated.
    values : dict of str -> ndarray
        The current values, shapes (k,), (N, k) or (N+1, k), read-only: a problem's p is
        formed of them once (`with_values` gives new ones).
    schedule : ParameterSchedule
        Their kinds and places in p.

    Examples
    --------
    >>> w = ProblemParameters({"weight": 2.0, "centre": [0.0, 1.0]}, 10)
    >>> w.vector().tolist(), w.with_values(weight=3.0).vector().tolist()
    ([2.0, 0.0, 1.0], [3.0, 0.0, 1.0])
    """

    def __init__(self, values, steps):
        if values is None:
            values = {}
        if not isinstance(values, dict):
            raise InputTypeError(f"`parameters` must be a dict of name -> value or None; got "
                                 f"{type(values).__name__}.")
        self.values = {}
        for name, value in values.items():
            if not isinstance(name, str) or not name.isidentifier():
                raise InputError(f"`parameters` names must be identifiers (str); got {name!r}.")
            self.values[name] = _value(f"parameters[{name!r}]", value, steps, clock=name == CLOCK)
        self.schedule = ParameterSchedule(self.values, steps)
        self.layout = self.schedule.layout

    @property
    def given(self):
        """True when there are parameters (then the user callables take `w`)."""
        return bool(self.values)

    def vector(self):
        """The stored values, shape (schedule.size,): the values raveled row by row (the
        knot indices 0 ... N after them with the clock), as p holds them."""
        return self.schedule.stored(self.values)

    def knot_values(self):
        """Step vectors at the knots, shape (schedule.step_size, N+1)
        (`ParameterSchedule.knot_indices`): column k gives the values at q_k at every
        fraction of a step."""
        return self.vector()[self.schedule.knot_indices()]

    def knot_points(self, h):
        """The values the callables read at the knots q_0 ... q_N, shape (layout.size, N+1):
        column k the point vector w at q_k (`knot_values` at any fraction of a step, the
        clock's entry t_0 + k `h`), as the NLP's knot rows read them."""
        values, at = self.knot_values(), self.schedule.point_function()
        return values if at is None else np.array(at.map(values.shape[1])(values, 0.0, h))

    def with_values(self, **values):
        """These parameters with some values replaced (same names and shapes)."""
        if values and not self.given:
            raise InputError(f"this problem has no parameters (got {sorted(values)}); give "
                             f"`parameters=` to OptimalControlProblem to make data re-solvable.")
        checks.no_unknown_keys("parameters", values, self.values)
        new = ProblemParameters.__new__(ProblemParameters)
        new.layout, new.schedule, new.values = self.layout, self.schedule, dict(self.values)
        for name, value in values.items():
            new.values[name] = _value(f"parameters[{name!r}]", value, self.schedule.steps,
                                      shape=self.values[name].shape, clock=name == CLOCK)
        return new

    def on_steps(self, steps):
        """These parameters on a grid of `steps` steps (the clock's knots anew); refused
        for values given along the horizon, whose rows belong to this grid."""
        along = [k for k, kind in self.schedule.kinds.items() if kind != FIXED]
        if along:
            raise InputError(f"`with_steps` cannot carry parameters given along the horizon to "
                             f"another N ({', '.join(repr(k) for k in along)}); build the problem "
                             f"on {steps} steps with their values there.")
        return ProblemParameters(self.values, steps)

    def symbols(self, w):
        """{name: block of the column symbol w} for the user callables."""
        return {name: w[self.layout.slice(name)] for name in self.layout.blocks}


def _value(name, value, steps, *, shape=None, clock=False):
    """`value` as a read-only float array of `shape`, or (shape None) of (k,), (N, k) or
    (N+1, k) (a scalar for the clock), finite."""
    out = checks.real_array(name, value, "a real number or an array of them")
    out = out.reshape(1) if out.ndim == 0 else out
    kinds = ("a scalar (the start time t_0 of the clock `t`)" if clock else
             f"a scalar or shape (k,) (fixed), (N, k) = ({steps}, k) (one row per step) or "
             f"(N+1, k) = ({steps + 1}, k) (one row per knot), k >= 1")
    if clock:
        fits, expected = out.shape == (1,), kinds
    elif shape is not None:
        fits, expected = out.shape == shape, f"shape {shape}"
    else:
        fits, expected = out.size > 0 and (out.ndim == 1 or (
            out.ndim == 2 and out.shape[0] in (steps, steps + 1))), kinds
    if not fits:
        raise InputError(f"`{name}` must be {expected}; got shape {np.shape(value)}.")
    if not np.isfinite(out).all():
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(out))[0])
        raise InputError(f"`{name}` must be finite; entry {bad} is {out[bad]}.")
    out = np.array(out, dtype=float)        # a copy of the caller's, made read-only
    out.flags.writeable = False
    return out


def cost_function(name, cost, system, args, parameters):
    """A user cost of (q, v[, u][, w]) checked on symbols, as the scalar Function
    ``(args..., w) -> cost``: w (the stacked parameters) is passed to `cost` as a dict
    {name: symbol} only when the problem has parameters."""
    _check_arity(name, cost, args, parameters)
    sizes = {"q": system.n, "v": system.n, "u": system.n_u}
    symbols = [ca.SX.sym(a, sizes[a]) for a in args] + [ca.SX.sym("w", parameters.layout.size)]
    return checked_function(name, _with_w(cost, parameters), symbols, (*args, "w"), (1, 1))


def path_function(path, system, parameters):
    """The user's path constraints path(q, v, u[, w]) at one state, checked on symbols, as
    the Function ``(q, v, u, w) -> g`` (g flattened to a column, imposed as g <= 0), w the
    values of `parameters` at that point (`ParameterSchedule.at`; the time there for the
    clock). The NLP evaluates it on the rule's interpolant at every step's interior points
    and at every knot with the knot velocity (`dmoc.optimal_control.nlp.path_terms`), the
    verdict at the knots of an optimum (`dmoc.drivers.verdict`)."""
    _check_arity("path_constraints", path, ("q", "v", "u"), parameters)
    symbols = [ca.SX.sym(a, k) for a, k in (("q", system.n), ("v", system.n), ("u", system.n_u),
                                            ("w", parameters.layout.size))]
    at_state = checked_function("path_constraints", _with_w(path, parameters), symbols,
                                ("q", "v", "u", "w"), None)
    g = ca.vec(at_state(*symbols))
    refuse_comparisons(g)
    return ca.Function("path_constraints", symbols, [g], ["q", "v", "u", "w"], ["g"])


def knot_rows(path):
    """The indices of the rows of the path constraints `path` (`path_function`) that read
    the configuration alone (not v, not u), a tuple of int: those a given end can be
    checked against and that keep a region of the plane out (`dmoc.results.kept_out`)."""
    q, v, u, w = (ca.SX.sym(name, path.size1_in(name)) for name in ("q", "v", "u", "w"))
    g = path(q, v, u, w)
    return tuple(i for i in range(g.numel()) if not ca.depends_on(g[i], ca.vertcat(v, u)))


def row_texts(path, system, layout, width=72):
    """The expression of each row of the path constraints `path` (`path_function`) as the
    user wrote it, with the system's coordinate names for q (v_<name> for v), its control
    names for u and the parameter names of `layout` (a block of size k as name_0 ...
    name_<k-1>), on one line, cut to `width` characters: how messages name a row besides
    its index."""
    def named(names):
        return ca.vertcat(*[ca.SX.sym(name) for name in names]) if names else ca.SX(0, 1)
    w = [name if layout.numel(name) == 1 else f"{name}_{j}"
         for name in layout.blocks for j in range(layout.numel(name))]
    return expression_texts(path(named(system.names), named([f"v_{name}" for name in system.names]),
                                 named(system.control_names), named(w)), width)


def expression_texts(g, width=72):
    """Each entry of the SX expression `g` on one line, cut to `width` characters."""
    texts = (" ".join(str(g[i]).split()) for i in range(g.numel()))
    return tuple(text if len(text) <= width else text[:width - 3] + "..." for text in texts)


def configuration_rows(path, q, w, free):
    """(g, rows): the rows g(q, 0, 0, w) of the path constraints `path` at the configuration
    `q` and parameter values `w` (SX), and the indices of those that read the configuration
    alone (`knot_rows`) and none of the SX symbols `free` (entries of q or w left free)."""
    g = path(q, ca.SX.zeros(path.size1_in("v")), ca.SX.zeros(path.size1_in("u")), w)
    return g, [i for i in knot_rows(path) if free.numel() == 0 or not ca.depends_on(g[i], free)]


def refuse_violated_ends(path, problem, made):
    """InputError when a given end, q_start or q_goal, violates a row of the path
    constraints that reads the configuration alone (`knot_rows`; every row is imposed at
    every knot, the ends included): such a problem has no solution. Rows that read a free entry
    of that end are not checked. `made` is a dict that keeps the check of each end per
    set of free entries (`_end_rows`: it depends on `path` and that set alone), shared by
    the problems of one NLP (`Transcription.with_bounds`), so that new boundary data are
    checked without building it again at every ``with_boundary`` (benchmarks/peers.py)."""
    points = None
    for end in ("q_start", "q_goal"):
        given = getattr(problem, end)
        key = (end, np.isfinite(given).tobytes())
        if key not in made:
            made[key] = _end_rows(path, problem, end, given)
        rows, at_end = made[key]
        if not rows:
            continue
        if points is None:
            points = problem.parameters.knot_points(problem.disc.h)
        w = points[:, 0 if end == "q_start" else -1]
        values = np.array(at_end(np.nan_to_num(given), w)).ravel()
        worst = int(np.argmax(values))
        if values[worst] > DEFAULT_IPOPT_OPTIONS["constr_viol_tol"]:
            raise InputError(
                f"`{end}` must satisfy `path_constraints` g <= 0, which hold at every knot q_0 "
                f"... q_N, the ends included; got g[{rows[worst]}] = "
                f"{values[worst]:.6g} there. "
                f"Move `{end}` or the constraint.")


def _end_rows(path, problem, end, given):
    """(the rows of `path` that read the configuration alone (`knot_rows`) and no free (NaN)
    entry of the end configuration `given`, nor, at q_goal of a free final time, the clock
    (the time t_0 + N h there is free), the Function (q, w) -> those rows at that end, w
    the values of the parameters there, or None without rows)."""
    q, w = ca.SX.sym("q", problem.disc.system.n), ca.SX.sym("w", problem.parameters.layout.size)
    free = q[np.flatnonzero(~np.isfinite(given)).tolist()]
    if end == "q_goal" and problem.free_time and CLOCK in problem.parameters.layout.blocks:
        free = ca.vertcat(free, w[problem.parameters.layout.slice(CLOCK)])
    g, rows = configuration_rows(path, q, w, free)
    return rows, ca.Function("at_end", [q, w], [g[rows]]) if rows else None


# CasADi's comparisons and logical operations: an entry that is one is a 0/1 value
_TRUTH_VALUES = (ca.OP_LT, ca.OP_LE, ca.OP_EQ, ca.OP_NE, ca.OP_NOT, ca.OP_AND, ca.OP_OR)


def refuse_comparisons(g):
    """InputError when an entry of the path constraints' expression `g` is a comparison
    (q[0] < 0.5): it is the 0/1 truth value, which `g <= 0` would impose as "false"."""
    for i in range(g.nnz()):
        entry = g.nz[i]
        if any(entry.is_op(op) for op in _TRUTH_VALUES):
            raise InputError(
                f"`path_constraints` must return expressions g imposed as g <= 0, not "
                f"comparisons; entry {i} is {entry} (a 0/1 truth value). Write q[0] < 0.5 "
                f"as `q[0] - 0.5` and a >= b as `b - a`.")


def _check_arity(name, fun, args, parameters):
    """InputTypeError when `fun` visibly takes the wrong number of arguments for whether
    the problem has parameters (its signature says so; callables without one pass)."""
    try:
        signature = inspect.signature(fun)
    except (TypeError, ValueError):
        return
    if any(p.kind == inspect.Parameter.VAR_POSITIONAL for p in signature.parameters.values()):
        return
    positional = [p for p in signature.parameters.values() if p.kind in (
        inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    required = sum(p.default is inspect.Parameter.empty for p in positional)
    expected = len(args) + parameters.given
    if not required <= expected <= len(positional):
        given = "with `parameters`" if parameters.given else "without `parameters`"
        listed = ", ".join((*args, "w") if parameters.given else args)
        raise InputTypeError(f"`{name}` must take ({listed}) {given}; it takes {len(positional)} "
                             f"positional arguments.")


def _with_w(fun, parameters):
    """`fun` called with the parameters' dict as its last argument, or without it when
    there are none."""
    if not callable(fun):
        return fun                      # checked_function names it
    if not parameters.given:
        return lambda *args: fun(*args[:-1])
    return lambda *args: fun(*args[:-1], parameters.symbols(args[-1]))
