"""``dmoc simulate`` and ``dmoc optimize``: set up a system from its name and the options,
run the simulator or the optimizer with ``throw=False``, print a summary and write the
output files, all of a run's files together (`dmoc._util.files.staged_run`). Returns the
exit code: 0 on success, 1 when the solver failed or its optimum failed the verdict
(`dmoc.drivers.verdict`), 130 when a Ctrl-C stopped it (what was computed is still written).
"""

import time

import numpy as np

from ..results import diagnostics
from ..discrete import discretize
from ..errors import Status
from ..principle import step_residual
from ..mechanics.rigid_body import RigidBody
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from ..optimal_control.statement.problem import OptimalControlProblem
from .body_commands import run_body
from ..drivers.optimum import optimize
from ..simulation.time_stepping import simulate
from . import arguments, output, registry
from .arguments import UsageError
from .runs import log, options_named, refuse_stated, report, run_name, staged_files


def _setup(args, spec, made):
    """(spec, the factory's system or problem, its system, output folder or None, file
    prefix) from the common options, for the `made` of `spec` (`_built`)."""
    system = made.disc.system if isinstance(made, OptimalControlProblem) else made
    spec = registry.with_heading(spec, args.heading, system.names)
    if args.animate and args.out is None:
        raise UsageError("--animate", "needs --out DIR to write the GIF into")
    out = arguments.output_folder("--out", args.out) if args.out is not None else None
    return spec, made, system, out, run_name(args)


def _built(args):
    """(spec, what its factory made: a system or a problem, on R^n or on SO(3))."""
    spec = registry.resolve(args.system)
    return spec, registry.build(spec, arguments.params(args.param))


def _on_group(made):
    """Whether `made` is a rigid body on SO(3) or its problem (`body_commands`)."""
    return isinstance(made, (RigidBody, GroupOptimalControlProblem))


def _default(option, value, spec_value, names, *, free=False):
    if value is not None:
        return arguments.vector(option, value, names, free=free)
    if spec_value is None:
        raise UsageError(option, "is required for a system from a file")
    return np.array([np.nan if s is None else s for s in spec_value], dtype=float)


def _with_none(q):
    """A vector of the command line with its free (NaN) entries as None, the API's mark."""
    return None if q is None else [None if np.isnan(x) else float(x) for x in q]


def _write(out, prefix, disc, traj, summary, spec, goal, args, problem=None):
    """Write the run's files into `out` together, or none of them (an earlier run's set
    stays whole); an interrupted run's without plots and GIF, so that it ends at once."""
    finished = summary["status"] != Status.INTERRUPTED
    return staged_files(out, prefix, lambda stage: output.write_all(
        stage, prefix, disc, traj, summary, spec, names=disc.system.names,
        control_names=spec.control_labels(disc.system), goal=goal, gif=args.animate and finished,
        plots=finished and not args.no_plots, problem=problem, progress=log))


def _discretization(system, rule, variant, h):
    """The discretization of ``--rule`` at the step h, its step residual of ``--variant``
    built (which refuses a rule without a one-step map) before anything is solved."""
    with options_named({"rule": "--rule", "h": "--duration"}):
        disc = discretize(system, h, rule or "midpoint")
        step_residual(disc, variant or "+")
    return disc


def _span(args, recorded):
    """(N, T) of a simulation: --steps and --duration, else the rows and times of the
    controls file (a T that differs from the file's would change its step h)."""
    steps = args.steps or (len(recorded.u) if recorded else 1000)
    if recorded and len(recorded.u) != steps:
        raise UsageError("--controls", f"must have one row per step, {steps} rows; got {len(recorded.u)}")
    if recorded is None or recorded.t is None:
        if recorded and args.duration is None:
            raise UsageError("--duration", f"is required with --controls {args.controls}, "
                             f"which has no t column: its controls were computed for some "
                             f"h = T/N")
        return steps, args.duration or 10.0
    T = recorded.t[-1] - recorded.t[0]
    if args.duration is not None and not np.isclose(args.duration, T, rtol=1e-12, atol=0.0):
        raise UsageError("--duration", f"is {args.duration:g}, but the controls of "
                         f"{args.controls} were computed over T = {T:.17g} (its t column); "
                         f"leave --duration out to replay them with their step h")
    return steps, T


def _simulated_start(args, spec, problem, recorded, names):
    """{q0, v0 or p0} of simulate: --start and --velocity; without both, the start of
    the table of --controls, else the problem's boundary data, else the built-in's."""
    if recorded and recorded.t is not None and args.start is None and args.velocity is None:
        return {"q0": recorded.q0, "p0": recorded.p0}
    zeros = (0.0,) * len(names)
    start = velocity = None
    if problem is not None:
        start, velocity = tuple(problem.q_start), tuple(problem.v_start)
        if np.isnan(start).any() and args.start is None:
            raise UsageError("--start", f"is required: the problem of {args.system} leaves "
                             f"entries of its start free")
    return {"q0": _default("--start", args.start, start or spec.start or zeros, names),
            "v0": _default("--velocity", args.velocity, velocity or spec.velocity or zeros, names)}


def run_simulate(args):
    """``dmoc simulate SYSTEM``; returns the exit code."""
    spec, made = _built(args)
    if _on_group(made):
        return run_body(args, made, run_name(args))
    spec, made, system, out, prefix = _setup(args, spec, made)
    problem = made if isinstance(made, OptimalControlProblem) else None
    if problem is not None:
        refuse_stated(args, ("--rule", "--variant"))
    variant = problem.variant if problem else args.variant or "+"
    recorded = (arguments.load_controls(args.controls, system.names, system.n_u)
                if args.controls else None)
    steps, duration = _span(args, recorded)
    disc = (problem.disc.with_step(duration / steps) if problem
            else _discretization(system, args.rule, variant, duration / steps))
    start = _simulated_start(args, spec, problem, recorded, system.names)
    log(f"simulating {steps} steps of {args.system} (h = {disc.h:.4g}, variant {variant})")
    tic = time.perf_counter()
    with options_named({"q0": "--start", "v0": "--velocity", "controls": "--controls"}):
        result = simulate(disc, **start, steps=steps, variant=variant, throw=False,
                          controls=None if recorded is None else recorded.u)
    log(f"done in {time.perf_counter() - tic:.2f} s")
    traj = result.trajectory
    summary = {"command": "simulate", "system": args.system, "status": result.status,
               "success": result.success, "steps": steps,
               "completed_steps": result.stats["completed_steps"], "h": disc.h,
               "rule": disc.rule.name, "variant": variant,
               "wall_time": result.stats["wall_time"],
               "max_constraint_violation": float(diagnostics.constraint_violation(disc, traj).max(initial=0.0)),
               "energy_drift": output.energy_drift(disc, traj),
               "max_residual": result.stats["max_residual"]}
    files = _write(out, prefix, disc, traj, summary, spec, None, args)
    return report(summary, result.success, result.status, result.message, files)


def _bounds(args, option, names):
    """(lower, upper) of --NAME-min and --NAME-max, None entries unbounded, or None."""
    lower, upper = (getattr(args, f"{option}_{end}") for end in ("min", "max"))
    if lower is None and upper is None:
        return None
    return tuple(None if text is None else _with_none(arguments.vector(
        f"--{option}-{end}", text, names, free=True)) for end, text in (("min", lower), ("max", upper)))


def _stated_problem(args, spec, system):
    """The OptimalControlProblem of the options for a system."""
    steps = args.steps or 100
    free_time = None if args.free_time is None else tuple(float(T) for T in arguments.vector(
        "--free-time", args.free_time, ("TMIN", "TMAX"), of="a time range"))
    duration = args.duration or (4.0 if free_time is None else sum(free_time) / 2)
    disc = _discretization(system, args.rule, args.variant, duration / steps)
    controls = spec.control_labels(system)
    with options_named({"q_start": "--start", "q_goal": "--goal", "v_start": "--velocity",
                        "control_bounds": "--control-min/--control-max", "duration": "--free-time",
                        "state_bounds": "--state-min/--state-max",
                        "velocity_bounds": "--velocity-min/--velocity-max"}):
        return OptimalControlProblem(
            disc, steps, variant=args.variant or "+", duration=free_time,
            q_start=_with_none(_default("--start", args.start, spec.start or (0.0,) * system.n,
                                        system.names, free=True)),
            q_goal=_with_none(_default("--goal", args.goal, spec.goal, system.names, free=True)),
            v_start=None if args.velocity is None else _with_none(
                arguments.vector("--velocity", args.velocity, system.names, free=True)),
            control_bounds=_bounds(args, "control", controls),
            state_bounds=_bounds(args, "state", system.names),
            velocity_bounds=_bounds(args, "velocity", system.names))


def _given_problem(args, problem):
    """The problem a file's factory returned, with the boundary data of --start, --goal
    and --velocity."""
    refuse_stated(args, ("--steps", "--rule", "--variant", "--duration", "--free-time",
                          "--control-min", "--control-max", "--state-min", "--state-max",
                          "--velocity-min", "--velocity-max"))
    names = problem.disc.system.names
    given = {key: _with_none(arguments.vector(option, text, names, free=True))
             for key, option, text in (("q_start", "--start", args.start),
                                       ("q_goal", "--goal", args.goal),
                                       ("v_start", "--velocity", args.velocity)) if text is not None}
    with options_named({"q_start": "--start", "q_goal": "--goal", "v_start": "--velocity"}):
        return problem.with_boundary(**given) if given else problem


def run_optimize(args):
    """``dmoc optimize SYSTEM``; returns the exit code."""
    spec, made = _built(args)
    if _on_group(made):
        return run_body(args, made, run_name(args))
    spec, made, system, out, prefix = _setup(args, spec, made)
    problem = (_given_problem(args, made) if isinstance(made, OptimalControlProblem)
               else _stated_problem(args, spec, system))
    options = {"max_iter": args.max_iter, "print_level": 5 if args.verbose else 0}
    log(f"optimizing {args.system} over {problem.steps} steps "
        f"({_time_span(problem)}) with IPOPT"
        + ("" if args.verbose else "; --verbose shows its iteration log"))
    result = optimize(problem, options=options, throw=False)
    log(f"IPOPT: {result.stats['return_status']} after {result.stats['iterations']} iterations "
        f"in {result.stats['solve_time']:.2f} s")
    traj = result.trajectory
    summary = {"command": "optimize", "system": args.system, "status": result.status,
               "success": result.success, "steps": problem.steps,
               "duration": float(traj.t[-1] - traj.t[0]), "free_time": problem.free_time,
               "rule": problem.disc.rule.name, "variant": problem.variant,
               **_figures(problem, result)}
    if result.verdict is not None:      # what the checks found, why a converged run failed
        summary.update(verdict=result.verdict.status, message=result.message)
    files = _write(out, prefix, problem.disc, traj, summary, spec, problem.q_goal, args, problem)
    return report(summary, result.success, result.status, result.message, files)


def _time_span(problem):
    """The final time as the log shows it: T = 4, or T free in [2, 8]."""
    if problem.free_time:
        return "T free in [{:g}, {:g}]".format(*problem.duration)
    return f"T = {problem.steps * problem.disc.h:g}"


def _figures(problem, result):
    """`diagnostics.optimization_summary` plus the energy drift; for a last iterate that
    holds NaN (nothing can be replayed from it) or one of a Ctrl-C (the user wants to
    stop, not to wait for a replay) only what IPOPT reported."""
    traj = result.trajectory
    if (result.status == Status.INTERRUPTED
            or not (np.isfinite(traj.q).all() and np.isfinite(traj.p).all())):
        return {"cost": result.cost, "iterations": result.stats["iterations"],
                "build_time": result.stats["build_time"], "solve_time": result.stats["solve_time"],
                "max_violation": result.stats["max_violation"]}
    figures = diagnostics.optimization_summary(problem, result)
    del figures["status"]
    figures["energy_drift"] = output.energy_drift(problem.disc, traj)
    return figures
