"""``dmoc simulate`` and ``dmoc optimize``: set up a system from its name and the options,
run the simulator or the optimizer with ``throw=False``, print a summary and write the
output files, all of a run's files together (`dmoc._util.files.staged_run`). Returns the
exit code: 0 on success, 1 when the solver failed or its optimum failed the verdict
(`dmoc.results.verdict`), 130 when a Ctrl-C stopped it (what was computed is still written).
"""

import contextlib
import re
import sys
import time

import numpy as np

from ..results import diagnostics
from ..discrete import discretize
from ..principle import step_residual
from ..optimize.problem import OptimalControlProblem
from ..results.verdict import optimize
from ..simulate.simulation import simulate
from .._util.files import staged_run
from . import arguments, output, registry
from .arguments import UsageError


def log(message):
    """Progress on stderr, so stdout keeps only the results."""
    print(f"dmoc: {message}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def options_named(mapping):
    """Turn a ValueError/TypeError of the library into a UsageError naming the CLI option
    that fed the argument the library names (its message quotes it in backticks)."""
    try:
        yield
    except (ValueError, TypeError) as err:
        message = str(err).splitlines()[0].rstrip(".")
        quoted = re.search(r"`([^`]+)`", message)
        name = quoted.group(1) if quoted else None
        raise UsageError(mapping.get(name, "SYSTEM"), message) from None


def _setup(args):
    """(spec, system, output folder or None, file prefix) from the common options."""
    spec = registry.resolve(args.system)
    system = registry.build(spec, arguments.params(args.param))
    if args.animate and args.out is None:
        raise UsageError("--animate", "needs --out DIR to write the GIF into")
    out = arguments.output_folder("--out", args.out) if args.out is not None else None
    prefix = re.sub(r"\W+", "_", args.system.rpartition(":")[2] or args.system)
    return spec, system, out, prefix


def _default(option, value, spec_value, names, *, free=False):
    if value is not None:
        return arguments.vector(option, value, names, free=free)
    if spec_value is None:
        raise UsageError(option, "is required for a system from a file")
    return np.array([np.nan if s is None else s for s in spec_value], dtype=float)


def _with_none(q):
    """A vector of the command line with its free (NaN) entries as None, the API's mark."""
    return [None if np.isnan(x) else float(x) for x in q]


def _report(summary, success, status, message, files):
    width = max(map(len, summary))
    for key, value in summary.items():
        shown = f"{value:.6g}" if isinstance(value, float) else value
        print(f"{key:{width}s}  {shown}")
    for path in files:
        print(f"wrote {path}")
    if status == INTERRUPTED:
        done = "wrote what was computed, without plots" if files else "nothing written (no --out)"
        log(f"{message.partition(';')[0].rstrip('.')}; {done}")
        return 130
    if not success:
        log(f"solver failed ({status}): {message}")
    return 0 if success else 1


INTERRUPTED = "interrupted"     # the status of a run stopped by Ctrl-C


def _write(out, prefix, disc, traj, summary, spec, goal, animate):
    """Write the run's files into `out` together, or none of them (an earlier run's set
    stays whole); an interrupted run's without plots and GIF, so that it ends at once."""
    if out is None:
        return []
    names = disc.system.names
    control_names = spec.control_names or tuple(f"u{i}" for i in range(disc.system.n_u))
    plots = summary["status"] != INTERRUPTED
    try:
        with staged_run(out, output.run_files(prefix)) as stage:
            written = output.write_all(stage, prefix, disc, traj, summary, spec, names=names,
                                       control_names=control_names, goal=goal,
                                       gif=animate and plots, plots=plots)
    except OSError as err:  # disk full, file-size limit, folder removed
        raise UsageError("--out", f"writing into {str(out)!r} failed: {err.strerror or err}; "
                         f"nothing there was changed (an earlier run's files are as they "
                         f"were, none of this run's was written)") from None
    return [out / path.name for path in written]


def _discretization(system, args, steps):
    """The discretization of ``--rule`` over ``--duration``, its step residual built (which
    refuses a rule without a one-step map) before anything is solved."""
    with options_named({"rule": "--rule", "h": "--duration"}):
        disc = discretize(system, args.duration / steps, args.rule)
        step_residual(disc, args.variant)
    return disc


def run_simulate(args):
    """``dmoc simulate SYSTEM``; returns the exit code."""
    spec, system, out, prefix = _setup(args)
    zeros = (0.0,) * system.n
    q0 = _default("--start", args.start, spec.start or zeros, system.names)
    v0 = _default("--velocity", args.velocity, spec.velocity or zeros, system.names)
    controls = arguments.load_controls(args.controls, system.n_u) if args.controls else None
    steps = args.steps or (len(controls) if controls is not None else 1000)
    if controls is not None and len(controls) != steps:
        raise UsageError("--controls", f"must have one row per step, {steps} rows; got {len(controls)}")
    disc = _discretization(system, args, steps)
    log(f"simulating {steps} steps of {args.system} (h = {disc.h:.4g}, variant {args.variant})")
    tic = time.perf_counter()
    with options_named({"q0": "--start", "v0": "--velocity", "controls": "--controls"}):
        result = simulate(disc, q0=q0, v0=v0, steps=steps, controls=controls,
                          variant=args.variant, throw=False)
    log(f"done in {time.perf_counter() - tic:.2f} s")
    traj = result.trajectory
    summary = {"command": "simulate", "system": args.system, "status": result.status,
               "success": result.success, "steps": steps,
               "completed_steps": result.stats["completed_steps"], "h": disc.h,
               "rule": args.rule, "variant": args.variant,
               "wall_time": result.stats["wall_time"],
               "max_constraint_violation": float(diagnostics.constraint_violation(disc, traj).max(initial=0.0)),
               "energy_drift": output.energy_drift(disc, traj),
               "max_residual": result.stats["max_residual"]}
    files = _write(out, prefix, disc, traj, summary, spec, None, args.animate)
    return _report(summary, result.success, result.status, result.message, files)


def run_optimize(args):
    """``dmoc optimize SYSTEM``; returns the exit code."""
    spec, system, out, prefix = _setup(args)
    q_start = _default("--start", args.start, spec.start or (0.0,) * system.n, system.names,
                       free=True)
    q_goal = _default("--goal", args.goal, spec.goal, system.names, free=True)
    steps = args.steps or 100
    disc = _discretization(system, args, steps)
    with options_named({"q_start": "--start", "q_goal": "--goal", "v_start": "--start",
                        "v_goal": "--goal"}):
        problem = OptimalControlProblem(disc, steps, q_start=_with_none(q_start),
                                        q_goal=_with_none(q_goal), variant=args.variant)
    options = {"max_iter": args.max_iter, "print_level": 5 if args.verbose else 0}
    log(f"optimizing {args.system} over {steps} steps (T = {args.duration:g}) with IPOPT"
        + ("" if args.verbose else "; --verbose shows its iteration log"))
    result = optimize(problem, options=options, throw=False)
    log(f"IPOPT: {result.stats['return_status']} after {result.stats['iterations']} iterations "
        f"in {result.stats['solve_time']:.2f} s")
    summary = {"command": "optimize", "system": args.system, "status": result.status,
               "success": result.success, "steps": steps, "duration": args.duration,
               "rule": args.rule, "variant": args.variant, **_figures(problem, result)}
    if result.verdict is not None:      # what the checks found, why a converged run failed
        summary.update(verdict=result.verdict.status, message=result.message)
    files = _write(out, prefix, disc, result.trajectory, summary, spec, q_goal, args.animate)
    return _report(summary, result.success, result.status, result.message, files)


def _figures(problem, result):
    """`diagnostics.optimization_summary` plus the energy drift; for a last iterate that
    holds NaN (nothing can be replayed from it) or one of a Ctrl-C (the user wants to
    stop, not to wait for a replay) only what IPOPT reported."""
    traj = result.trajectory
    if (result.status == INTERRUPTED
            or not (np.isfinite(traj.q).all() and np.isfinite(traj.p).all())):
        return {"cost": result.cost, "iterations": result.stats["iterations"],
                "build_time": result.stats["build_time"], "solve_time": result.stats["solve_time"],
                "max_violation": result.stats["max_violation"]}
    figures = diagnostics.optimization_summary(problem, result)
    del figures["status"]
    figures["energy_drift"] = output.energy_drift(problem.disc, traj)
    return figures
