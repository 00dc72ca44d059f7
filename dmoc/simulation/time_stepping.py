"""Consumer 1 of the step residual: the Dirac integrator. Each step solves the residual R
of (37) (variant "+") or (41) (variant "-") by Newton's method (`dmoc.simulation.stepper`),
the horizon evaluated in compiled chunks (`mapaccum`); results keep every converged step.
A run is checked and started by `dmoc.simulation.preparation` and concluded here.
"""

import time

import numpy as np

from ..discrete.group_discretization import GroupDiscretization
from ..errors import InputError
from ..principle.trajectory import Trajectory
from .feedback_law import closed_loop
from .group_stepping import simulate_on_group
from .outcome import SimulationResult, finished_result, interrupted_result, run_stats
from .preparation import prepare


def simulate(disc, *, q0, v0=None, p0=None, steps, controls=None, feedback=None, variant="+",
             throw=True, tol=1e-12, max_iter=50, jit=None):
    """Simulate the implicit discrete Lagrange-d'Alembert equations (37) or (41).

    Parameters
    ----------
    disc : Discretization or GroupDiscretization
        A GroupDiscretization (a `RigidBody` or a `FloatingBaseRobot` on SO(3) x R^n_x)
        is simulated on the group (`dmoc.simulation.group_stepping.simulate_on_group`):
        q0 is then the rotation R_0, shape (3, 3), or the pair (R_0, x_0), v0 the body
        angular velocity then x'_0 and p0 the momentum (Pi_0, p_x,0), shape (3 + n_x,),
        and the trajectory a RotationTrajectory.
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
    feedback : FeedbackGains, optional
        Close the loop: the controls of step k are ``feedback.control(k, q_k, p_k)`` at the
        state the simulation reached (for `dmoc.tvlqr`'s gains u*_k - K_k (x_k - x*_k)), so
        `disc` may be a plant other than the model the gains were taken on (another mass,
        another rule of as many controls per step); the trajectory's ``u`` are the controls
        applied. Excludes `controls`; needs variant "+", `steps` at most the gains' horizon
        and `disc.h` equal to their trajectory's h. Any object with a ``trajectory`` and a
        method ``control(k, q, p)`` returning shape (disc.n_controls,) is a law. The steps
        then go one at a time (the same step solve as without it, never a whole horizon in
        one compiled call).
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
        unrolled Newton iterations, or two to eight chord updates for a dense step of more than
        four unknowns without multipliers, as a robot's) did not converge.
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
    p_{k+1} follows from the "right" rows (see `dmoc.simulation.stepper`).
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
    if isinstance(disc, GroupDiscretization):
        if feedback is not None:
            raise InputError("`feedback` is not available for a GroupDiscretization (a rigid body "
                             "on SO(3)): its gains would need the group step's linearization.")
        return simulate_on_group(disc, q0=q0, v0=v0, p0=p0, steps=steps, controls=controls,
                                 variant=variant, throw=throw, tol=tol, max_iter=max_iter, jit=jit)
    run = prepare(disc, q0=q0, v0=v0, p0=p0, steps=steps,
                  controls=None if feedback is not None else controls, variant=variant,
                  throw=throw, tol=tol, max_iter=max_iter, jit=jit)
    law = None
    if feedback is not None:
        run.controls, law = closed_loop(run, feedback, controls)
    return conclude(run, run.stepper.run(run.start, run.controls, disc.h, law))


def conclude(run, stepped, *, final=False):
    """The SimulationResult of `run` from what its stepper returned (`DiracStepper.run`):
    the trajectory of the steps kept (of its last knot only when `final`, as
    `Trajectory.assembled` cuts it), the stats, and the verdict (raised with `throw`)."""
    acc, out, failed_rnorm, redone, interrupted, continued = stepped
    wall = time.perf_counter() - run.tic
    stepper, k = run.stepper, out.shape[0]
    traj = _assemble(stepper, run.formulation, run.disc, run.controls[:k], acc, out, final)
    rnorm = out[:, stepper.out.slice("rnorm")]
    stats = _stats(run, k, redone, continued, float(rnorm.max()) if k else 0.0, wall)
    if interrupted:
        return interrupted_result(traj, stats, run.throw)
    explain = getattr(run.disc.system, "step_failure_hint", None)
    hint = explain(traj.q[-1], traj.p[-1], run.disc.h) if explain and k < stats["steps"] else None
    return finished_result(traj, stats, failed_rnorm, run.tol, run.throw, hint)


def conclude_group(runs, controls, acc, out, stepped, *, final=False, memory=np.empty):
    """`conclude` of each of `runs`, R runs stepped in lockstep (`run_lockstep`) under
    `controls` (R, N, n_controls) into `acc` (R, N+1, state.size) and `out` (R, N,
    out.size), of which each of `stepped` (what `DiracStepper.run` returns) holds views:
    the runs that completed every step concluded together, their trajectories rows of one
    array per field in one buffer, ``memory(size)`` (`Trajectory.assembled_runs`), the
    others one by one. The same results as `conclude` of each run, but that a
    trajectory's arrays are views."""
    N = acc.shape[1] - 1
    results, whole = [None] * len(runs), []
    for i, (_, o, _, _, cut, _) in enumerate(stepped):
        if o.shape[0] == N and not cut:
            whole.append(i)
        else:                                               # failed or interrupted
            results[i] = conclude(runs[i], stepped[i], final=final)
    if whole:
        now = time.perf_counter()
        rows = slice(None) if len(whole) == len(runs) else whole
        first = runs[whole[0]]
        trajectories = _assemble(first.stepper, first.formulation, first.disc, controls[rows],
                                 acc[rows], out[rows], final, memory)
        largest = out[rows, :, first.stepper.out.slice("rnorm")].max(axis=(1, 2))
        for i, traj, rnorm in zip(whole, trajectories, largest):
            stats = _stats(runs[i], N, stepped[i][3], stepped[i][5], float(rnorm), now - runs[i].tic)
            results[i] = finished_result(traj, stats, None, runs[i].tol, runs[i].throw)
    return results


def _stats(run, k, redone, continued, max_residual, wall):
    """`run_stats` of `run` after `k` completed steps, `wall` seconds after its `tic`."""
    return run_stats(run.controls.shape[0], k, redone, continued, max_residual, run.stepper.native, wall)


def _assemble(stepper, formulation, disc, controls, acc, out, final, memory=np.empty):
    """Trajectory from the horizon's states (the start first) and per-step outputs
    (time-major arrays), its fields copied as ``Trajectory(...)`` copies them, without its
    checks (`Trajectory.assembled`, of the last knot only when `final`; mu None, a (-)
    run that failed at its first step, is no impulse); of runs in lockstep along a leading
    axis of `controls`, `acc` and `out`, the list of their Trajectories, copied into
    ``memory(size)`` (`Trajectory.assembled_runs`)."""
    h = disc.h
    state, per_step = stepper.state.split(acc), stepper.out.split(out)
    p, lam, mu = formulation.trajectory_blocks(state["p"], per_step["p0"], per_step["nu"],
                                               stepper.residual.m)
    t = np.broadcast_to(h * np.arange(acc.shape[-2]), acc.shape[:-1])
    fields = (t, state["q"], p, lam, controls, h, formulation.name, mu, per_step["s"],
              disc.rule.control_nodes, disc.rule.stage_nodes, final)
    if acc.ndim == 2:
        return Trajectory.assembled(*fields)
    return Trajectory.assembled_runs(*fields, memory)
