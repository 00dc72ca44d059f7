"""``dmoc simulate`` and ``dmoc optimize`` of a rigid body on SO(3) x R^n_x (a file's
factory returning a `RigidBody` or a `GroupOptimalControlProblem`): rotations given on the
command line as rotation vectors (axis times angle), the run made by the public API with
``throw=False``, and its files written together: the RotationTrajectory (.npz), a JSON
summary and the body's plots (`dmoc.plotting.plot_body`, `plot_body_rates`), and with
``--animate`` its GIF (`dmoc.animation.animate_body`).
"""

import json

import numpy as np

from .._util.files import write_text
from ..discrete.group_discretization import GroupDiscretization
from ..drivers.optimum import optimize
from ..errors import Status
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem, rotation_matrix
from ..results._canvas import save_png
from ..results.body_animation import animate_body
from ..results.body_figure import plot_body, plot_body_rates
from ..simulation.time_stepping import simulate
from . import arguments, output
from .arguments import UsageError
from .runs import log, options_named, refuse_stated, report, staged_files


def run_body(args, made, prefix):
    """``dmoc simulate|optimize`` of the body or problem `made` (files named `prefix`);
    returns the exit code."""
    _refuse(args, ("--rule", "--variant"), "its one rule is the midpoint rule on the group")
    _refuse(args, ("--heading",), "its heading is its rotation, drawn as the body's axes")
    if args.animate and args.out is None:
        raise UsageError("--animate", "needs --out DIR to write the GIF into")
    out = arguments.output_folder("--out", args.out) if args.out is not None else None
    run = _simulated if args.command == "simulate" else _optimized
    summary, result = run(args, made)
    files = staged_files(out, prefix, lambda stage: _written(stage, prefix, result.trajectory,
                                                             summary, args))
    return report(summary, result.success, result.status, result.message, files)


def _refuse(args, options, why):
    """UsageError for the first of `options` given, which a body on SO(3) does not take."""
    for option in options:
        if getattr(args, option[2:].replace("-", "_"), None) not in (None, False):
            raise UsageError(option, f"is not taken for a rigid body on SO(3) ({why})")


def _names(body, prefix):
    """The entries of a state vector: the 3 of a rotation vector or of Omega, then x."""
    return [f"{prefix}{i}" for i in (1, 2, 3)] + [f"x{i}" for i in range(1, body.n_x + 1)]


def _configuration(option, text, body, default):
    """(R, x) of ``--start``/``--goal``: the rotation vector (3 entries, rad) then x (n_x),
    or `default` when the option is not given."""
    if text is None:
        return default
    values = arguments.vector(option, text, _names(body, "phi"), of=f"{body.name!r} (a rotation "
                              f"vector, axis times angle in rad, then x)")
    return rotation_matrix(values[:3]), values[3:]


def _velocity(args, body):
    """(Omega, x') of ``--velocity``, shape (3 + n_x,)."""
    return arguments.vector("--velocity", args.velocity, _names(body, "Omega"), of=repr(body.name))


def _simulated(args, made):
    """(summary, SimulationResult) of ``dmoc simulate``."""
    _refuse(args, ("--controls",), "its runs from the command line are free motions")
    given = isinstance(made, GroupOptimalControlProblem)
    body = made.disc.system if given else made
    steps, duration = args.steps or 1000, args.duration or 10.0
    disc = GroupDiscretization(body, duration / steps)
    R0, x0 = _configuration("--start", args.start, body, (made.R_start, made.x_start) if given
                            else (np.eye(3), np.zeros(body.n_x)))
    mass = np.array(body.generalized_mass(np.concatenate([R0.ravel(), x0])))
    v0 = (np.linalg.solve(mass, made.p_start) if given
          else np.zeros(body.n)) if args.velocity is None else _velocity(args, body)
    log(f"simulating {steps} steps of {args.system} (h = {disc.h:.4g}, on SO(3))")
    with options_named({"q0": "--start", "v0": "--velocity"}):
        result = simulate(disc, q0=(R0, x0) if body.n_x else R0, v0=v0, steps=steps, throw=False)
    traj = result.trajectory
    energy = np.array([float(body.energy(q, p)) for q, p in zip(traj.q, traj.p)])
    return {"command": "simulate", "system": args.system, "status": result.status,
            "success": result.success, "steps": steps,
            "completed_steps": result.stats["completed_steps"], "h": disc.h, "rule": "midpoint",
            "wall_time": result.stats["wall_time"],
            "max_orthogonality_defect": float(traj.orthogonality_defect.max()),
            "energy_drift": float(np.abs(energy - energy[0]).max()),
            "max_residual": result.stats["max_residual"]}, result


def _optimized(args, made):
    """(summary, OptimizationResult) of ``dmoc optimize``."""
    if isinstance(made, GroupOptimalControlProblem):
        refuse_stated(args, ("--steps", "--duration", "--start", "--goal", "--velocity"))
    problem = made if isinstance(made, GroupOptimalControlProblem) else _stated_problem(args, made)
    log(f"optimizing {args.system} over {problem.steps} steps (T = {problem.duration:g}) with "
        f"IPOPT on SO(3)" + ("" if args.verbose else "; --verbose shows its iteration log"))
    result = optimize(problem, options={"max_iter": args.max_iter, "print_level": 5 if args.verbose else 0},
                      throw=False)
    log(f"IPOPT: {result.stats['return_status']} after {result.stats['iterations']} iterations "
        f"in {result.stats['solve_time']:.2f} s")
    summary = {"command": "optimize", "system": args.system, "status": result.status,
               "success": result.success, "steps": problem.steps, "duration": problem.duration,
               "rule": "midpoint", "cost": result.cost, "iterations": result.stats["iterations"],
               "max_violation": result.stats["max_violation"],
               "replay_deviation": result.stats.get("replay_deviation", np.nan),
               "max_orthogonality_defect": float(result.trajectory.orthogonality_defect.max())}
    if not result.success:
        summary["message"] = result.message
    return summary, result


def _stated_problem(args, body):
    """The GroupOptimalControlProblem of the options for a body with controls."""
    refuse_stated(args, ("--free-time", "--control-min", "--control-max", "--state-min",
                          "--state-max", "--velocity-min", "--velocity-max"))
    if args.goal is None:
        raise UsageError("--goal", "is required for a rigid body: the rotation vector (rad) of "
                         "R_goal" + (", then x" if body.n_x else ""))
    steps, duration = args.steps or 100, args.duration or 4.0
    R0, x0 = _configuration("--start", args.start, body, (np.eye(3), np.zeros(body.n_x)))
    R1, x1 = _configuration("--goal", args.goal, body, None)
    v0 = np.zeros(body.n) if args.velocity is None else _velocity(args, body)
    coordinates = ({"x_start": x0, "x_goal": x1, "x_velocity_start": v0[3:]} if body.n_x else {})
    with options_named({"disc": "SYSTEM", "R_start": "--start", "x_start": "--start",
                        "R_goal": "--goal", "x_goal": "--goal", "omega_start": "--velocity",
                        "x_velocity_start": "--velocity"}):
        return GroupOptimalControlProblem(GroupDiscretization(body, duration / steps), steps,
                                          R_start=R0, R_goal=R1, omega_start=v0[:3], **coordinates)


def _written(stage, prefix, traj, summary, args):
    """Write the trajectory, the summary and, unless --no-plots or after a Ctrl-C, the
    body's plots (its frames in space for x of 0, 2 or 3 entries) and with --animate its
    GIF into `stage`; return their paths."""
    written = [stage / f"{prefix}.npz", stage / f"{prefix}_summary.json"]
    traj.save(written[0])
    write_text(written[1], json.dumps({k: output.json_value(v) for k, v in summary.items()},
                                      indent=2) + "\n")
    if summary["status"] == Status.INTERRUPTED or not np.isfinite(traj.q).all():
        return written
    drawable = traj.x.shape[1] in (0, 2, 3)
    if args.animate and drawable:
        written.append(animate_body(traj, stage / f"{prefix}.gif", title=prefix))
    if args.no_plots:
        return written
    if drawable:
        written.append(stage / f"{prefix}_path.png")
        save_png(plot_body(traj, title=f"{prefix}: the body"), written[-1])
    if traj.steps:
        written.append(stage / f"{prefix}_states.png")
        save_png(plot_body_rates(traj, title=f"{prefix}: angular velocity, velocity, controls"),
                 written[-1])
    return written
