"""The runs of the Dirac integrator checked and started (consumer 1 of the step residual):
`simulate`'s arguments checked in its order, the start momentum p_0 = dL/dv(q_0, v_0),
the controls at every control node and the stepper of the run's residual (`Run`); many
runs at once share what they can (`prepare_runs`, for runs in lockstep).
"""

import os
import time
from dataclasses import dataclass

import numpy as np

from .._util import checks
from .._util import compiled
from .._util.cache import BoundedCache
from ..mechanics.given import given_start, start_momenta
from ..discrete import Discretization
from ..errors import InputError
from ..principle.formulations import as_formulation
from ..principle.residual import step_residual
from .stepper import DiracStepper


@dataclass
class Run:
    """A run of `simulate` checked and ready to step (`prepare`): its discretization,
    formulation, stepper (shared by every run of the same residual, tol, max_iter and
    jit), start state (stepper.state.size,), controls (steps, disc.n_controls), `throw`,
    `tol`, and the `perf_counter` time its stepper was asked for (where wall_time starts)."""

    disc: Discretization
    formulation: object
    stepper: DiracStepper
    start: np.ndarray
    controls: np.ndarray
    throw: bool
    tol: float
    tic: float


def prepare(disc, *, q0, v0=None, p0=None, steps, controls=None, variant="+", throw=True,
            tol=1e-12, max_iter=50, jit=None):
    """The arguments of `simulate` checked, and what its steps start from: the start
    momentum (``v0`` through dL/dv), the controls at every control node, the stepper
    (`prepare_runs` of one run). Raises as `simulate` does for a bad argument."""
    run = prepare_runs(disc, [dict(q0=q0, v0=v0, p0=p0, steps=steps, controls=controls,
                                   variant=variant, throw=throw, tol=tol, max_iter=max_iter,
                                   jit=jit)])[0]
    if isinstance(run, Exception):
        raise run
    return run


def prepare_runs(disc, runs):
    """`prepare` of each of `runs` (dicts of its keyword arguments), what they share done
    once: the scalar checks of runs of equal scalars (`_scalars`), the q0, v0 and p0
    given as plain numbers checked as one array (`_plain_rows`), the start momenta p_0 =
    dL/dv(q0, v0) and the velocity checks of all runs in mapped calls (`start_momenta`:
    the bits of one run's), one stepper lookup for runs of the same formulation, tol,
    max_iter and jit, one memory check per length, one array of zero controls (read-only)
    for runs of the same length without controls, the start states of the runs of one
    stepper as rows of one array (`_starts`).

    Returns
    -------
    list
        For each run its `Run`, or the exception `prepare` raises for it alone: its first
        failed check, in the order of `simulate`'s checks.
    """
    checks.instance("disc", disc, Discretization, "a Discretization")
    shared, rows = {}, _plain_rows(disc.system.n, runs)
    given = [_attempt(_given, shared, rows.get(i, {}), disc, **run) for i, run in enumerate(runs)]
    velocity = [i for i, g in enumerate(given) if isinstance(g, dict) and g["v0"] is not None]
    if velocity:
        q0, v0 = (np.array([given[i][name] for i in velocity]) for name in ("q0", "v0"))
        momenta, errors = start_momenta(disc.system, q0, v0)
        for i, p, error in zip(velocity, momenta, errors):
            given[i] = error or dict(given[i], p0=p)
    ready = [g if isinstance(g, Exception) else _attempt(_ready, disc, g, shared) for g in given]
    _starts(disc, [(run, g) for run, g in zip(ready, given) if isinstance(run, Run)])
    return ready


def _attempt(function, *args, **kwargs):
    """``function(*args, **kwargs)``, or the exception it raises."""
    try:
        return function(*args, **kwargs)
    except Exception as err:        # the run's own error, raised or kept by the caller
        return err


def _given(shared, rows, /, disc, *, q0, v0=None, p0=None, steps, controls=None, variant="+",
           throw=True, tol=1e-12, max_iter=50, jit=None):
    """The checks of one run up to its start velocity or momentum (`given_start`), in
    `simulate`'s order: the checked arguments by name. `shared` holds what the runs of
    one call share (`_scalars`), `rows` this run's q0, v0 and p0 checked already
    (`_plain_rows`)."""
    formulation, steps, tol, max_iter, throw = _scalars(shared, disc, variant, steps, tol,
                                                        max_iter, throw)
    q0 = rows["q0"] if "q0" in rows else checks.array("q0", q0, (disc.system.n,))
    v0, p0 = given_start(disc.system, q0, rows.get("v0", v0), rows.get("p0", p0), tuple(rows))
    return dict(formulation=formulation, steps=steps, tol=tol, max_iter=max_iter, throw=throw,
                q0=q0, v0=v0, p0=p0, controls=controls, jit=jit)


# types whose equal values pass or fail `_scalars`' checks alike, to the same values
_SCALAR_TYPES = frozenset({bool, int, float, str, np.float64, np.int64})


def _scalars(shared, disc, variant, steps, tol, max_iter, throw):
    """(formulation, steps, tol, max_iter, throw) checked in `simulate`'s order, kept in
    `shared` under their types and values when each is of `_SCALAR_TYPES` (the checks
    of equal values of one such type give equal results), for the runs after."""
    given = (variant, steps, tol, max_iter, throw)
    key = (("scalars",) + tuple((type(a), a) for a in given)
           if all(type(a) in _SCALAR_TYPES for a in given) else None)
    checked = shared.get(key)
    if checked is None:
        checked = (as_formulation(variant, disc), checks.positive_int("steps", steps),
                   checks.positive_float("tol", tol), checks.positive_int("max_iter", max_iter),
                   checks.boolean("throw", throw))
        if key is not None:
            shared[key] = checked
    return checked


# the exact types of numbers in a list or tuple that `_plain_rows` checks together: as
# one float array they become what `checks.array` makes of each (ints up to 2^53 exactly)
_PLAIN_NUMBERS = frozenset({float, np.float64, int})
_EXACT_INT = 2 ** 53


def _plain_rows(n, runs):
    """{index: {name: row}} of the q0, v0 and p0 of `runs` that are plain, finite
    numbers: a float64 array of shape (n,), or a list or tuple of n floats and ints (of
    at most 2^53 in size), checked and converted together (one float array of all of
    them) into the values `checks.array` gives each; any other value is left to
    `checks.array` of its own run, whose errors name it."""
    chosen = [(i, name) for i, run in enumerate(runs) if isinstance(run, dict)
              for name in ("q0", "v0", "p0") if _plain(run.get(name), n)]
    if not chosen:
        return {}
    values = np.array([runs[i][name] for i, name in chosen], dtype=float)
    rows = {}
    for (i, name), row, finite in zip(chosen, values, np.isfinite(values).all(axis=1)):
        if finite:
            rows.setdefault(i, {})[name] = row
    return rows


def _plain(value, n):
    """Whether `value` is n plain numbers (`_plain_rows`)."""
    if type(value) is np.ndarray:
        return value.dtype == np.float64 and value.shape == (n,)
    if type(value) not in (list, tuple) or len(value) != n:
        return False
    kinds = set(map(type, value))
    return kinds <= _PLAIN_NUMBERS and (
        int not in kinds or all(-_EXACT_INT <= x <= _EXACT_INT for x in value if type(x) is int))


def _ready(disc, given, shared):
    """The Run of the `given` arguments (`_given`, with the start momentum p0), the checks
    after the start's in `simulate`'s order; `shared` holds what runs of one call share."""
    steps = given["steps"]
    if ("memory", steps) not in shared:
        _check_memory(disc, steps)
        shared[("memory", steps)] = True
    if given["controls"] is None:
        controls = shared.get(("zeros", steps))
        if controls is None:
            controls = shared[("zeros", steps)] = step_controls(disc, None, steps)
            controls.flags.writeable = False
    else:
        controls = step_controls(disc, given["controls"], steps)
    key = (given["formulation"], given["tol"], given["max_iter"], given["jit"])
    tic = time.perf_counter()
    stepper = shared.get(key) if given["jit"] is None or isinstance(given["jit"], bool) else None
    if stepper is None:
        stepper = shared[key] = _stepper(disc, *key)
    return Run(disc, given["formulation"], stepper, None, controls, given["throw"], given["tol"], tic)


def _starts(disc, ready):
    """The `start` of each Run of the (Run, given arguments) pairs `ready` (`_ready`): q0,
    p0 and h v0 (zeros without v0), the first Newton increment; those of the runs of one
    stepper rows of one array, made together."""
    steppers = {}
    for run, given in ready:
        steppers.setdefault(id(run.stepper), []).append((run, given))
    for members in steppers.values():
        state, n = members[0][0].stepper.state, disc.system.n
        starts = np.zeros((len(members), state.size))
        starts[:, state.slice("q")] = [given["q0"] for _, given in members]
        starts[:, state.slice("p")] = [given["p0"] for _, given in members]
        starts[:, state.slice("dq")] = disc.h * np.array(
            [np.zeros(n) if given["v0"] is None else given["v0"] for _, given in members])
        for (run, _), start in zip(members, starts):
            run.start = start


def _stepper(disc, formulation, tol, max_iter, jit):
    """The DiracStepper of `disc`'s residual in `formulation` (`step_residual`, checked as
    for `simulate`), kept across calls (`_STEPPERS`)."""
    residual = step_residual(disc, formulation)
    native = native_choice(jit)
    return _STEPPERS.get((residual.key, tol, max_iter, native),
                         lambda: DiracStepper(residual, tol, max_iter, native))


_STEPPERS = BoundedCache(16, "steppers")     # keyed by (residual key, tol, max_iter, native): h is an input


def native_choice(jit):
    """`jit` checked: None, or True (then a C compiler must exist), or False."""
    if jit is None:
        return None
    if checks.boolean("jit", jit) and compiled.compiler() is None:
        raise InputError("`jit=True` needs a C compiler: none found (set CC to one, or use "
                         "jit=None to fall back to CasADi's virtual machine).")
    return jit


def memory_needed(disc, steps):
    """Bytes of the float arrays a run of `steps` steps holds at once: the stepper's states
    (q, p, dq, nu, s) and per-step outputs (p0, nu, s and 4 scalars), the controls, and the
    Trajectory's t, q, p, lam, u, s; a lower bound (CasADi's work arrays come on top)."""
    n, m, ns, nc = disc.system.n, disc.n_multipliers, disc.n_stages, disc.n_controls
    per_step = (3 * n + m + ns) + (n + m + ns + 4) + nc + (1 + 2 * n + m + nc + ns)
    return 8 * (steps + 1) * per_step


def physical_memory():
    """Bytes of memory of this machine, or None where the OS does not say."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):        # no sysconf (Windows), or no such name
        return None


def _check_memory(disc, steps):
    """Refuse, naming `steps`, a run whose arrays alone would not fit in the machine's memory."""
    needed, available = memory_needed(disc, steps), physical_memory()
    if available is not None and needed > available:
        raise InputError(f"`steps` = {steps} needs at least {needed:.3g} bytes for the "
                         f"trajectory's arrays, more than this machine's memory "
                         f"({available:.3g} bytes); simulate fewer steps, or the horizon in "
                         f"pieces (each run starting from the last state of the previous).")


def step_controls(disc, controls, steps):
    """`controls` as an array (steps, disc.n_controls): zeros if None; a control held over
    each step, shape (steps, n_u), is repeated at every control node of the rule."""
    n_u, nodes = disc.system.n_u, len(disc.rule.control_nodes)
    if controls is None:
        return np.zeros((steps, disc.n_controls))
    try:
        shape = np.shape(controls)
    except ValueError:           # ragged: `checks.array` below names it
        shape = None
    if nodes > 1 and shape == (steps, n_u):
        controls = np.tile(checks.array("controls", controls, (steps, n_u)), (1, nodes))
    return checks.array("controls", controls, (steps, disc.n_controls))
