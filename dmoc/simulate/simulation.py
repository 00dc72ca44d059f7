"""Consumer 1 of the step residual: the Dirac integrator. Each step solves the residual R
of (37) (variant "+") or (41) (variant "-") by Newton's method (`dmoc.simulate.stepper`),
the horizon evaluated in compiled chunks (`mapaccum`); results keep every converged step.
"""

import os
import time
from dataclasses import dataclass, field

import numpy as np

from .._util import checks
from .._util import compiled
from .._util.cache import BoundedCache
from ..mechanics.given import given_start, start_momenta
from ..discrete import Discretization
from ..errors import InputError, Interrupted, SolverError
from ..principle.formulations import as_formulation
from ..principle.residual import step_residual
from .stepper import DiracStepper
from ..principle.trajectory import Trajectory


@dataclass
class SimulationResult:
    """Outcome of `simulate`.

    Attributes
    ----------
    trajectory : Trajectory
        All steps that converged (all of them when `success`).
    success : bool
    status : str
        ``"converged"``, ``"newton_failed"``, ``"non_finite"`` (a step produced NaN/Inf)
        or ``"interrupted"`` (Ctrl-C; ``throw=False``).
    message : str
    stats : dict
        ``steps`` requested, ``completed_steps``, ``robust_steps`` (steps the line-search
        Newton redid), ``max_residual`` (max-norm of R over the completed steps, checked
        at every step on both paths), ``native`` (True when the fast path ended the run as
        compiled C), ``wall_time`` in seconds (building or loading the compiled step included).
    """

    trajectory: Trajectory
    success: bool
    status: str
    message: str
    stats: dict = field(default_factory=dict)


def simulate(disc, *, q0, v0=None, p0=None, steps, controls=None, variant="+",
             throw=True, tol=1e-12, max_iter=50, jit=None):
    """Simulate the implicit discrete Lagrange-d'Alembert equations (37) or (41).

    Parameters
    ----------
    disc : Discretization
    q0 : array_like, shape (n,)
        Initial configuration.
    v0, p0 : array_like, shape (n,)
        Initial velocity (then p_0 = dL/dv(q0, v0)) or initial momentum: exactly one.
        `v0` must lie in Delta_Q(q0) = ker A(q0).
    steps : int
        Number of steps N; refused (InputError) when the run's arrays (`memory_needed`)
        would exceed the machine's memory.
    controls : array_like, shape (N, disc.n_controls) or (N, n_u), optional
        The controls of each step at the rule's control nodes, node by node (for the
        midpoint and trapezoid rules one control u_k held on [t_k, t_{k+1}]); a shape
        (N, n_u) array is held over each step for any rule. Zeros by default. A
        Trajectory's ``u`` has this form, so ``controls=traj.u`` replays it.
    variant : {"+", "-"} or Formulation
        The form of the equations (`dmoc.formulations`).
    throw : bool
        Raise SolverError on a Newton failure and `dmoc.Interrupted` on Ctrl-C (default);
        else return the result with success=False and status ``"newton_failed"``,
        ``"non_finite"`` or ``"interrupted"``. Either way the result keeps every step
        completed before (see Notes).
    tol : float
        Newton's target for the residual max-norm; a step whose residual stays above
        1000 tol counts as failed. Below ``ROUNDOFF_FLOOR / 1000`` (2.2e-17) round-off
        alone keeps the residual above that, and the failure message says so.
    max_iter : int
        Iterations of the line-search Newton that redoes a step the fast path (three
        unrolled Newton iterations) did not converge.
    jit : bool or None
        Run the fast path as C code, compiled once per step Function with the system's C
        compiler and cached on disk across calls and processes (`dmoc._util.compiled`;
        compiled once, then loaded), several times faster per step than CasADi's virtual
        machine, with the same results. None (default): C when it is cached, else once
        this process has spent 0.5 s (about the cost of compiling) in the virtual machine
        on this step Function, mid-run if need be; without a C compiler, always the
        virtual machine. True: C now (an error without a compiler); False: never, with a
        lighter step Function (no common-subexpression elimination: cheaper to build, as
        fast in the virtual machine), whose results equal the compiled ones to round-off
        rather than bit for bit (None and True compute the same bits in either form).

    Returns
    -------
    SimulationResult

    Notes
    -----
    Variant "+": given (q_k, p_k, u_k), Newton solves R = 0 for (q_{k+1}, lam_k), and
    p_{k+1} follows from the "right" rows (see `dmoc.simulate.stepper`).
    Variant "-": p_k of (41) is fixed only up to A(q_k)^T mu by the previous step, so each
    step solves R for (q_{k+1}, mu) with p_k = p_k' - A(q_k)^T mu, p_k' the momentum
    carried in; mu is the previous step's multiplier (lam_{k-1}), and at k = 0 it is the
    initial impulse ``trajectory.mu``. Nothing fixes the impulse at q_N, so a (-) run ends
    with lam_{N-1} = 0 and p_N = D2 L_d + f_d^+ (the next step would apply it).

    A KeyboardInterrupt (Ctrl-C, SIGINT) while the steps run stops the run after the steps
    accepted so far: the chunk of steps being evaluated when it arrived is dropped (its
    steps are not checked yet), every earlier step is kept. With ``throw=True`` it raises
    `dmoc.Interrupted`, a KeyboardInterrupt whose ``.result`` is that SimulationResult;
    with ``throw=False`` the result is returned, status ``"interrupted"``, success False,
    ``stats["completed_steps"]`` the steps kept. An interrupt before the first chunk
    (while the step is built or compiled) is a plain KeyboardInterrupt.

    Examples
    --------
    >>> import dmoc
    >>> disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    >>> res = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=10)
    >>> res.trajectory.q.shape, res.success
    ((11, 3), True)
    """
    run = prepare(disc, q0=q0, v0=v0, p0=p0, steps=steps, controls=controls, variant=variant,
                  throw=throw, tol=tol, max_iter=max_iter, jit=jit)
    return conclude(run, run.stepper.run(run.start, run.controls, disc.h))


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
    once: the start momenta p_0 = dL/dv(q0, v0) and the velocity checks of all runs in
    mapped calls (`start_momenta`: the bits of one run's), one stepper lookup for runs of
    the same formulation, tol, max_iter and jit, one array of zero controls (read-only)
    for runs of the same length without controls.

    Returns
    -------
    list
        For each run its `Run`, or the exception `prepare` raises for it alone: its first
        failed check, in the order of `simulate`'s checks.
    """
    checks.instance("disc", disc, Discretization, "a Discretization")
    given = [_attempt(_given, disc, **run) for run in runs]
    velocity = [i for i, g in enumerate(given) if isinstance(g, dict) and g["v0"] is not None]
    if velocity:
        q0, v0 = (np.array([given[i][name] for i in velocity]) for name in ("q0", "v0"))
        momenta, errors = start_momenta(disc.system, q0, v0)
        for i, p, error in zip(velocity, momenta, errors):
            given[i] = error or dict(given[i], p0=p)
    shared = {}
    return [g if isinstance(g, Exception) else _attempt(_ready, disc, g, shared) for g in given]


def _attempt(function, *args, **kwargs):
    """``function(*args, **kwargs)``, or the exception it raises."""
    try:
        return function(*args, **kwargs)
    except Exception as err:        # the run's own error, raised or kept by the caller
        return err


def _given(disc, *, q0, v0=None, p0=None, steps, controls=None, variant="+", throw=True,
           tol=1e-12, max_iter=50, jit=None):
    """The checks of one run up to its start velocity or momentum (`given_start`), in
    `simulate`'s order: the checked arguments by name."""
    formulation = as_formulation(variant, disc)
    steps = checks.positive_int("steps", steps)
    tol = checks.positive_float("tol", tol)
    max_iter = checks.positive_int("max_iter", max_iter)
    throw = checks.boolean("throw", throw)
    q0 = checks.array("q0", q0, (disc.system.n,))
    v0, p0 = given_start(disc.system, q0, v0, p0)
    return dict(formulation=formulation, steps=steps, tol=tol, max_iter=max_iter, throw=throw,
                q0=q0, v0=v0, p0=p0, controls=controls, jit=jit)


def _ready(disc, given, shared):
    """The Run of the `given` arguments (`_given`, with the start momentum p0), the checks
    after the start's in `simulate`'s order; `shared` holds what runs of one call share."""
    steps = given["steps"]
    _check_memory(disc, steps)
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
    start = np.zeros(stepper.state.size)
    v_guess = np.zeros(disc.system.n) if given["v0"] is None else given["v0"]
    for name, value in (("q", given["q0"]), ("p", given["p0"]), ("dq", disc.h * v_guess)):
        start[stepper.state.slice(name)] = value
    return Run(disc, given["formulation"], stepper, start, controls, given["throw"], given["tol"], tic)


def _stepper(disc, formulation, tol, max_iter, jit):
    """The DiracStepper of `disc`'s residual in `formulation` (`step_residual`, checked as
    for `simulate`), kept across calls (`_STEPPERS`)."""
    residual = step_residual(disc, formulation)
    native = _native(jit)
    return _STEPPERS.get((residual.key, tol, max_iter, native),
                         lambda: DiracStepper(residual, tol, max_iter, native))


def conclude(run, stepped, *, final=False):
    """The SimulationResult of `run` from what its stepper returned (`DiracStepper.run`):
    the trajectory of the steps kept (of its last knot only when `final`, as
    `Trajectory.assembled` cuts it), the stats, and the verdict (raised with `throw`)."""
    acc, out, failed_rnorm, redone, interrupted = stepped
    wall = time.perf_counter() - run.tic
    stepper, k = run.stepper, out.shape[0]
    traj = _assemble(stepper, run.formulation, run.disc, run.controls[:k], acc, out, final)
    rnorm = out[:, stepper.out.slice("rnorm")]
    stats = {"steps": run.controls.shape[0], "completed_steps": k, "robust_steps": redone,
             "max_residual": float(rnorm.max()) if k else 0.0, "native": stepper.native,
             "wall_time": wall}
    if interrupted:
        return _interrupted(traj, stats, run.throw)
    return _finish(traj, stats, failed_rnorm, run.tol, run.throw)


# the smallest residual relative to the momenta that a converged step can be asked for:
# 100 units of round-off (evaluating R sums and multiplies O(n) terms of size |p|)
ROUNDOFF_FLOOR = 100 * np.finfo(float).eps

_STEPPERS = BoundedCache(16, "steppers")     # keyed by (residual key, tol, max_iter, native): h is an input


def _native(jit):
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


def _assemble(stepper, formulation, disc, controls, acc, out, final):
    """Trajectory from the horizon's states (the start first) and per-step outputs
    (time-major arrays), its fields copied as ``Trajectory(...)`` copies them, without its
    checks (`Trajectory.assembled`, of the last knot only when `final`; mu None, a (-)
    run that failed at its first step, is no impulse)."""
    h = disc.h
    state, per_step = stepper.state.split(acc), stepper.out.split(out)
    p, lam, mu = formulation.trajectory_blocks(state["p"], per_step["p0"], per_step["nu"],
                                               stepper.residual.m)
    return Trajectory.assembled(h * np.arange(acc.shape[0]), state["q"], p, lam, controls, h,
                                formulation.name, mu, per_step["s"], disc.rule.control_nodes,
                                disc.rule.stage_nodes, final)


def _interrupted(traj, stats, throw):
    """The result of a run stopped by Ctrl-C after ``stats["completed_steps"]`` accepted
    steps."""
    k = stats["completed_steps"]
    result = SimulationResult(
        traj, False, "interrupted",
        f"interrupted (KeyboardInterrupt) after {k} of {stats['steps']} steps (t = "
        f"{k * traj.h:.6g}); the {k} completed steps are in `.result.trajectory`.", stats)
    if throw:
        raise Interrupted(result.message, result)
    return result


def _finish(traj, stats, failed_rnorm, tol, throw):
    """Report success, or the failed step with the trajectory before it."""
    k, steps = stats["completed_steps"], stats["steps"]
    if k == steps:
        return SimulationResult(traj, True, "converged",
                                f"{steps} steps converged (max residual {stats['max_residual']:.2e}).", stats)
    where = f"at step {k} (t = {k * traj.h:.6g})"
    if np.isnan(failed_rnorm):
        status, what = "non_finite", (
            f"step {k} turned NaN or Inf (t = {k * traj.h:.6g}): the residual, the next state or "
            f"the multipliers are not finite; check the force and the controls of step {k}.")
    else:
        hint = (f"`tol` = {tol:.1e} is below the round-off floor: 1000 tol is less than the "
                f"{ROUNDOFF_FLOOR:.1e} (100 units of round-off, relative to the momenta) "
                f"that evaluating the residual reaches; use tol >= {ROUNDOFF_FLOOR / 1e3:.1e} "
                f"(default 1e-12)"
                if 1e3 * tol < ROUNDOFF_FLOOR else "try a smaller step h or check the controls")
        status, what = "newton_failed", (
            f"Newton did not converge {where}: residual max-norm {failed_rnorm:.3e} > 1000 tol "
            f"= {1e3 * tol:.1e} (relative to the momenta) after the iteration limit; {hint}.")
    result = SimulationResult(
        traj, False, status, what + f" The trajectory up to step {k} is in `.result.trajectory`.",
        stats)
    if throw:
        raise SolverError(result.message, result)
    return result
