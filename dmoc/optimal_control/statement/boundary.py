"""The optimizer's boundary data: which entries of q_0 and q_N a problem may give on
holonomic constraints, when the step rows already impose g(q_k) = 0 at every node
(docs/holonomic.md), where the velocity rows A(q) v = 0 are imposed, and a start given by
its momentum instead of its velocity; `set_boundary` sets them, checked, on an
OptimalControlProblem (built, or copied by `with_boundary`).
"""

import math

import numpy as np

from ..._util import checks

from ...mechanics.given import check_allowed_velocity, check_configuration
from ...errors import InputError
from .read_only import frozen


def boundary_vector(name, value, n):
    """Boundary data of shape (n,) with None entries as NaN (free); never infinite. A list
    or tuple of n finite floats (NumPy's too) and None, a re-solve's new goal, is taken at
    once, checked in Python: a NumPy call on data this short costs more than the check
    (benchmarks/peers.py resolve)."""
    if type(value) in (list, tuple) and len(value) == n and all(
            x is None or (isinstance(x, float) and math.isfinite(x)) for x in value):
        return np.array([np.nan if x is None else x for x in value])
    if value is None:
        raise InputError(f"`{name}` is required: an array of shape ({n},), None entries free.")
    if type(value) not in (list, tuple) and np.ndim(value) == 0:      # a list is no scalar
        raise InputError(f"`{name}` must have shape ({n},) for this system; got ().")
    out = checks.array_with_none(name, value, n, np.nan)     # floats of shape (n,), no NaN
    if np.isinf(out).any():
        checks.array(name, out, (n,), allow_nan=True)       # refuses it, naming the entry
    return out


def check_holonomic_boundary(system, q_start, q_goal):
    """Raise ValueError before an optimal control problem is solved if its boundary
    configurations do not fit the holonomic constraints g(q) = 0 of `system`.

    Parameters
    ----------
    system : MechanicalSystem
    q_start, q_goal : ndarray, shape (n,)
        Boundary configurations, NaN entries free.

    Raises
    ------
    ValueError
        `q_start` with free entries (the step rows impose g(q_{k+1}) = 0, k = 0 ... N-1, so
        nothing would impose g(q_0) = 0); a fully given `q_start` or `q_goal` off g = 0; or
        a `q_goal` that over-determines g: the step rows already impose g(q_N) = 0, so at
        most n - k entries can be given. The message names the entries to leave free (None):
        those whose columns of dg/dq(q_goal) are best conditioned (QR with column pivoting).

    Notes
    -----
    A fully given goal on g = 0 satisfies g(q_N) = 0 redundantly: the NLP's constraint
    Jacobian is rank-deficient there and IPOPT may report success at a point that is not
    the optimum. With those entries free the goal is the same set, stated once.
    """
    k, n = system.n_holonomic, system.n
    if k == 0:
        return
    if not np.isfinite(q_start).all():
        raise InputError(
            "`q_start` must be fully given for a system with holonomic constraints: the step "
            "rows impose g(q_{k+1}) = 0, so free start entries would leave g(q_0) = 0 unimposed.")
    check_configuration("q_start", system, q_start)
    given = np.flatnonzero(np.isfinite(q_goal))
    if len(given) == n:
        check_configuration("q_goal", system, q_goal)
    if len(given) <= n - k:
        return
    jacobian = np.array(system.constraint_matrix(np.nan_to_num(q_goal)))[system.m - k:]
    free = sorted(int(i) for i in given[pivot_columns(jacobian[:, given], len(given) - (n - k))])
    raise InputError(
        f"`q_goal` over-determines the holonomic constraints: the step rows impose the k = {k} "
        f"equations g(q_N) = 0, so at most n - k = {n - k} of its entries can be given; it gives "
        f"{len(given)}. Leave entries {free} {tuple(system.names[i] for i in free)} free "
        f"(None): the goal set is the same, and the NLP stays regular.")


def pivot_columns(matrix, count):
    """Indices of `count` columns of `matrix` chosen as QR with column pivoting chooses
    them: each the column of largest norm after removing the span of those chosen."""
    rest, chosen = np.array(matrix, dtype=float), []
    for _ in range(count):
        j = int(np.argmax(np.linalg.norm(rest, axis=0)))
        chosen.append(j)
        e = rest[:, j] / np.linalg.norm(rest[:, j])
        rest = rest - np.outer(e, e @ rest)
    return np.array(chosen, dtype=int)


def outside_bounds(q, lower, upper):
    """(i, q[i], below, bound) for each entry of `q` outside the box [lower, upper] (shapes
    (n,)): `below` True for one under its lower bound, `bound` the one it crosses; a free
    entry (NaN) is neither. Read as Python floats: NumPy's comparisons of arrays this short
    cost more in a re-solve (benchmarks/peers.py resolve)."""
    return [(i, x, x < low, low if x < low else high)
            for i, (x, low, high) in enumerate(zip(q.tolist(), lower.tolist(), upper.tolist()))
            if x < low or x > high]


def fully_given(q, v):
    """True when the boundary configuration q and velocity v, shapes (n,), have no free
    (NaN) entries."""
    return not (_has_free(q) or _has_free(v))


def imposes_velocity_rows(complete, v):
    """Whether A(q) v = 0 is imposed at an end with velocity data v (NaN free), whose q and
    v are `complete` (`fully_given`): unless they are (then checked once,
    `check_allowed_velocity`) or v is given and zero (then the rows vanish for every q;
    imposing them would make the KKT matrix singular)."""
    return not (complete or not (_has_free(v) or any(v.tolist())))


def _has_free(data):
    """Whether the boundary data `data`, shape (n,), have a free (NaN) entry; read as
    Python floats: NumPy's reductions of arrays this short cost more in a re-solve
    (benchmarks/peers.py resolve)."""
    return any(map(math.isnan, data.tolist()))


def start_momentum(p_start, v_start, n):
    """`p_start` as a read-only array of shape (n,), or None when not given; exclusive with
    `v_start` and fully given (finite)."""
    if p_start is None:
        return None
    if v_start is not None:
        raise InputError("give the start as `v_start` or as `p_start`, not both: the start "
                         "rows impose p_0 = dL/dv(q_0, v_start) or p_0 = p_start.")
    p_start = checks.array("p_start", p_start, (n,))
    p_start.flags.writeable = False
    return p_start


def set_boundary(problem, given):
    """Set the boundary data in `given` ({name: value} among q_start, q_goal, v_start,
    v_goal, p_start; a start momentum replaces the start velocity) on the
    OptimalControlProblem `problem`, being built or a fresh copy, and check the ends whose
    data they change; the other data, and where their ends impose velocity rows, stay as
    they were, checked."""
    n, sys = problem._disc.system.n, problem._disc.system
    for name in ("q_start", "q_goal"):
        if name in given:
            setattr(problem, "_" + name, frozen(boundary_vector(name, given[name], n)))
    if "p_start" in given or "v_start" in given:
        problem._p_start = start_momentum(given.get("p_start"), given.get("v_start"), n)
        v_start = given.get("v_start")
        problem._v_start = frozen(boundary_vector(
            "v_start", [None] * n if problem._p_start is not None else np.zeros(n) if v_start is None
            else v_start, n))
    if "v_goal" in given:
        problem._v_goal = frozen(boundary_vector("v_goal", given["v_goal"], n))
    if "q_start" in given or "q_goal" in given:
        check_holonomic_boundary(sys, problem._q_start, problem._q_goal)
    ends = [end for end, names in _END_DATA.items() if not given.keys().isdisjoint(names)]
    rows = dict(getattr(problem, "_velocity_rows", {}))      # a copy's own
    for end in ends:
        q, v = getattr(problem, "_q_" + end), getattr(problem, "_v_" + end)
        complete = fully_given(q, v)
        if complete and given.keys() & {"q_" + end, "v_" + end}:
            check_allowed_velocity("v_" + end, sys, q, v)
        # a start given by its momentum has no velocity rows
        rows[end] = imposes_velocity_rows(complete, v) and (end == "goal" or problem._p_start is None)
    for names, bounds in ((("q_start", "q_goal"), "state_bounds"),
                          (("v_start", "v_goal"), "velocity_bounds")):
        for name in (k for k in names if k in given):
            _refuse_outside(name, getattr(problem, "_" + name), bounds, getattr(problem, "_" + bounds),
                            sys.names)
    problem._velocity_rows = rows


def _refuse_outside(name, data, bounds, box, names):
    """InputError naming every entry of the boundary data `data` (called `name`) outside
    the box `box` = (lower, upper) of the problem's `bounds`, with its value and the bound it
    crosses; free entries (NaN) pass."""
    outside = [f"{name}[{i}] ({names[i]}) = {x:.6g} {'<' if below else '>'} {bound:.6g}"
               for i, x, below, bound in outside_bounds(data, *box)]
    if outside:
        raise InputError(f"`{name}` must lie within `{bounds}`; {', '.join(outside)}.")


# the boundary data of each end: given any of them, that end's checks and velocity rows are
# made again (`set_boundary`)
_END_DATA = {"start": ("q_start", "v_start", "p_start"), "goal": ("q_goal", "v_goal")}
