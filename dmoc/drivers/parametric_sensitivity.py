"""Parametric sensitivities of an optimum (a driver: feedback and what-if without re-solving):
the derivatives of the optimal NLP vector, trajectory, controls and cost in the problem's
boundary data and parameters, from the KKT system at the optimum
(`dmoc.drivers.kkt_sensitivity`). The data enter the NLP affinely, through its parameter
vector p and the bounds lbx = ubx they fix, so their derivatives are read off the
transcriptions of the problem and of one perturbed copy per entry (`with_boundary`,
`with_parameters`: the same NLP).
"""

import dataclasses

import numpy as np

from .._util import checks
from ..errors import InputError
from ..optimal_control import OptimalControlProblem, OptimizationResult
from .kkt_sensitivity import solve_kkt

BOUNDARY_DATA = ("q_start", "q_goal", "v_start", "v_goal", "p_start")


@dataclasses.dataclass(frozen=True)
class Sensitivities:
    """Derivatives of an optimum in the problem's data (`sensitivities`).

    Each dict is keyed by the names of `wrt`; a datum of shape s (e.g. (n,) for q_goal,
    () for a scalar parameter) gives arrays whose trailing axes are s.

    Attributes
    ----------
    wrt : tuple of str
        The data differentiated in.
    cost : dict of str -> ndarray, shape s
        dJ/dtheta.
    q : dict of str -> ndarray, shape (N+1, n) + s
        dq_k/dtheta of the optimal configurations.
    u : dict of str -> ndarray, shape (N, n_controls) + s
        du_k/dtheta of the optimal controls (at the rule's control nodes).
    x : dict of str -> ndarray, shape (problem.transcription.x_layout.size,) + s
        dx/dtheta of the NLP vector in the system's units (its block "q" is q - q_ref).
    active : dict
        ``"g"``: the rows of g held at a bound (the equality rows and the active inequality
        rows), ``"x"``: the entries of x held at a bound (the boundary data and active
        bounds), arrays of int.
    """

    wrt: tuple
    cost: dict
    q: dict
    u: dict
    x: dict
    active: dict


def sensitivities(problem, result, *, wrt):
    """The derivatives of the optimum `result` of `problem` in its data `wrt`, from the KKT
    system at the optimum.

    Parameters
    ----------
    problem : OptimalControlProblem
    result : OptimizationResult
        An optimum of `problem` (or of a problem of the same `structure` with these data),
        with its x and multipliers.
    wrt : str or tuple of str
        Names of boundary data (``"q_start"``, ``"q_goal"``, ``"v_start"``, ``"v_goal"``,
        ``"p_start"``, the last when the problem gives it) or of the problem's
        `parameters`. An entry left free (NaN) has zero derivatives. A velocity datum
        (v_start, v_goal) of a system with velocity constraints moves off them along a
        coordinate, which `with_boundary` refuses.

    Returns
    -------
    Sensitivities

    Raises
    ------
    InputError
        An unknown name, a result of another NLP or without multipliers, or a KKT matrix
        that is singular at the optimum.

    Notes
    -----
    At a local optimum where the active constraints are linearly independent, the second
    order conditions hold strictly and the active set does not change (strict
    complementarity), the optimum is a differentiable function of the data theta, and
    differentiating the KKT conditions of the scaled NLP (stationarity of f + lam_g^T g +
    lam_x^T x, the active rows of g and the active entries of x at their bounds) gives a
    linear system in (dx, dlam) with the Lagrangian's Hessian and the active rows'
    Jacobian (`solve_kkt`) [1]. The active set is that of the result's multipliers
    (`dmoc.drivers.kkt_sensitivity.active_sets`): the derivatives are one-sided where a bound is about to become
    active or inactive. dJ/dtheta = grad f . dx/dtheta + df/dp dp/dtheta; by the envelope
    theorem it also equals the derivative of the Lagrangian in theta at fixed (x, lam):
    for q_goal, minus the result's ``lam_x`` at the q_N entries.

    References
    ----------
    .. [1] A. V. Fiacco, "Sensitivity analysis for nonlinear programming using penalty
       methods", Mathematical Programming 10 (1976) 287-311.

    Examples
    --------
    >>> import dmoc, dmoc.problems
    >>> problem = dmoc.problems.knife_edge_parking(20)
    >>> result = dmoc.optimize(problem)
    >>> d = dmoc.sensitivities(problem, result, wrt="q_goal")
    >>> d.cost["q_goal"].shape, d.q["q_goal"].shape
    ((3,), (21, 3, 3))
    """
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    checks.instance("result", result, OptimizationResult, "an OptimizationResult")
    names = (wrt,) if isinstance(wrt, str) else tuple(wrt)
    T = problem.transcription
    if result.x is None or result.lam_g is None or result.structure != problem.structure:
        raise InputError("`result` must be an optimum of `problem` (the same `structure`) with its x "
                         "and multipliers; re-solve `problem` for one.")
    columns = [_columns(problem, name) for name in names]
    d_p, lower, upper = (np.hstack([c[i] for c in columns]) for i in range(3))
    xs, lam_gs, lam_xs = result.x / T.x_scale, result.lam_g / T.g_scale, result.lam_x * T.x_scale
    dxs, d_cost, g_rows, x_rows = solve_kkt(T, xs, lam_gs, lam_xs, d_p, lower / T.x_scale[:, None],
                                            upper / T.x_scale[:, None])
    return _in_user_shapes(problem, names, dxs * T.x_scale[:, None], d_p, d_cost,
                           {"g": g_rows, "x": x_rows})


def _columns(problem, name):
    """(dp, dlbx, dubx) of datum `name`, shapes (n_p, k), (n_x, k), (n_x, k) for its k
    entries: the differences of the transcriptions of copies of `problem` with one entry
    moved, divided by the move (exact up to rounding: the data enter p and the bounds
    affinely); zero where a bound is infinite or the entry free."""
    value = _value(problem, name)
    T, flat = problem.transcription, value.ravel()
    cols = ([], [], [])
    for i in range(flat.size):
        if not np.isfinite(flat[i]):
            for c, size in zip(cols, (T.p.size, T.lbx.size, T.ubx.size)):
                c.append(np.zeros(size))
            continue
        step = 2.0 ** (np.floor(np.log2(max(1.0, abs(flat[i])))) - 10)
        moved = flat.copy()
        moved[i] += step
        other = _moved(problem, name, moved.reshape(value.shape)).transcription
        if other.structure != T.structure:
            raise InputError(f"`wrt` names {name!r}, whose change gives this problem another NLP "
                             f"(e.g. v_goal at a partly free goal: its velocity rows change): "
                             f"no derivative.")
        for c, a, b in zip(cols, (T.p, T.lbx, T.ubx), (other.p, other.lbx, other.ubx)):
            finite = np.isfinite(a) & np.isfinite(b)
            c.append(np.subtract(b, a, out=np.zeros(a.size), where=finite) / step)
    return tuple(np.array(c).T.reshape(-1, flat.size) for c in cols)


def _value(problem, name):
    """The current value of datum `name` (a float array), checked as a name."""
    if not isinstance(name, str):
        raise InputError(f"`wrt` must name boundary data or parameters (str); got {name!r}.")
    if name in BOUNDARY_DATA:
        value = getattr(problem, name)
        if name == "v_start" and problem.p_start is not None:
            raise InputError("`wrt` names 'v_start', but this problem starts from p_start: "
                             "differentiate in 'p_start'.")
        if value is None:
            raise InputError(f"`wrt` names {name!r}, which this problem does not give.")
        return np.asarray(value, dtype=float)
    values = problem.parameter_values
    if name not in values:
        known = ", ".join(repr(k) for k in BOUNDARY_DATA + tuple(values))
        raise InputError(f"`wrt` must name boundary data or parameters of the problem ({known}); got {name!r}.")
    return np.asarray(values[name], dtype=float)


def _moved(problem, name, value):
    """`problem` with datum `name` set to `value` (the same NLP)."""
    if name in BOUNDARY_DATA:           # a free entry (NaN) stays free: None
        return problem.with_boundary(**{name: [None if np.isnan(v) else v for v in value]})
    return problem.with_parameters(**{name: value})


def _in_user_shapes(problem, names, dx, d_p, d_cost, active):
    """The Sensitivities of the columns dx (n_x, k) and d_p (n_p, k), in the order of
    `names`' entries."""
    T, out, start = problem.transcription, {"cost": {}, "q": {}, "u": {}, "x": {}}, 0
    d_q_ref = d_p[T.p_layout.slice("q_ref")]
    for name in names:
        shape = _value(problem, name).shape
        cols = range(start, start + int(np.prod(shape)))
        start = cols.stop
        out["x"][name] = dx[:, cols].reshape(-1, *shape)
        q = np.stack([T.x_layout.unpack(dx[:, j], "q").T + d_q_ref[:, j] for j in cols], axis=-1)
        u = np.stack([T.x_layout.unpack(dx[:, j], "u").T for j in cols], axis=-1)
        out["q"][name] = q.reshape(*q.shape[:2], *shape)
        out["u"][name] = u.reshape(*u.shape[:2], *shape)
        out["cost"][name] = d_cost[list(cols)].reshape(shape)
    return Sensitivities(names, out["cost"], out["q"], out["u"], out["x"], active)
