"""``dmoc demo``: simulates the built-in systems against their closed-form solutions,
solves the two DMOC examples (knife-edge parking, rolling-disk steering) with both
variants, replays each optimum, and writes a summary and three figures (the simulations,
each optimum), all of them together
(`dmoc._util.files.staged_run`): a failed or interrupted demo leaves ``--out`` as it was.
"""

import numpy as np

from ..results import diagnostics
from ..optimal_control.statement import examples as problems
from ..mechanics import systems
from .._util.files import staged_run, write_text
from ..discrete import discretize
from ..errors import Status
from ..drivers.optimum import optimize
from ..results._canvas import figure, save_png
from ..results.plotting import plot_controls, plot_energy_balance, plot_energy_error, plot_path
from ..simulation.time_stepping import simulate
from . import arguments
from .arguments import UsageError
from .registry import BUILT_IN

# Unforced demo runs: (name, built-in, its closed-form solution, final time).
_DEMOS = (
    ("knife_edge", "knife-edge", systems.knife_edge(incline=0.2),
     lambda t, q0, v0: systems.knife_edge_solution(t, q0, v0, incline=0.2), 10.0),
    ("rolling_disk", "rolling-disk", systems.rolling_disk(),
     lambda t, q0, v0: systems.rolling_disk_solution(t, q0, v0), 10.0),
)


def simulation_demo(out, steps, lines):
    """Simulate each demo system with both variants; append summary lines to `lines`; save
    one figure: each system's path against the exact one, and its energy error."""
    lines += [f"{'system':14s} {'variant':7s} {'steps':>6s} {'max |q - q_exact|':>18s} "
             f"{'max |omega_d|':>14s} {'max|E-E0|':>13s} {'time [s]':>9s}"]
    fig, grid = _grid_figure(9.0, 6.4, 2, 2, height_ratios=(2, 1))
    for column, (name, key, system, exact, T) in enumerate(_DEMOS):
        spec = BUILT_IN[key]
        q0, v0 = np.array(spec.start), np.array(spec.velocity)
        disc = discretize(system, T / steps)
        for variant in ("+", "-"):
            res = simulate(disc, q0=q0, v0=v0, steps=steps, variant=variant)
            traj = res.trajectory
            q_exact, _ = exact(traj.t, q0, v0)
            E = diagnostics.energy(disc, traj)
            lines.append(
                f"{name:14s} {variant:7s} {steps:6d} {np.abs(traj.q - q_exact).max():18.3e} "
                f"{diagnostics.constraint_violation(disc, traj).max():14.3e} "
                f"{np.abs(E - E[0]).max():13.3e} {res.stats['wall_time']:9.4f}")
        path, energy = fig.add_subplot(grid[0, column]), fig.add_subplot(grid[1, column])
        plot_path(traj, heading=spec.heading, labels=system.names[:2], units=system.units,
                  title=f"{name}: path ({steps} steps)", ax=path)
        path.plot(q_exact[:, 0], q_exact[:, 1], "k--", lw=0.8, label="exact")
        path.legend(fontsize="small")
        plot_energy_error(disc, traj, time_unit=system.units["t"], title=f"{name}: energy error",
                          ax=energy)
    save_png(fig, out / "simulation.png")


def _grid_figure(width, height, rows, columns, **spacing):
    """A Figure of `width` x `height` inches and a grid of rows x columns to place Axes in."""
    fig, (ax,) = figure(1, width=width, height=height)
    ax.remove()
    return fig, fig.add_gridspec(rows, columns, left=0.08, right=0.98, bottom=0.09, top=0.93,
                                 hspace=0.5, wspace=0.28, **spacing)


def optimization_demo(out, steps, lines):
    """Solve the two DMOC examples with both variants; append summary lines to `lines`,
    return whether all succeeded; save each variant's trajectory (a failed solve's last
    iterate included) and one figure of each example: path, controls, energy balance."""
    ok = True
    for name, key, make in (("knife_edge_parking", "knife-edge", problems.knife_edge_parking),
                            ("rolling_disk_steering", "rolling-disk", problems.rolling_disk_steering)):
        spec = BUILT_IN[key]
        for variant, suffix in (("+", "plus"), ("-", "minus")):
            problem = make(steps, variant=variant)
            result = optimize(problem, throw=False)
            if result.status == Status.INTERRUPTED:     # Ctrl-C stops the whole demo
                raise KeyboardInterrupt(result.message)
            ok &= result.success
            title = f"{name} (variant {variant}, N = {steps})"
            if np.isfinite(result.trajectory.q).all():
                lines.append(diagnostics.format_summary(
                    title, diagnostics.optimization_summary(problem, result)))
            else:
                lines.append(f"{title}: {result.message}")
            result.trajectory.save(out / f"{name}_{suffix}.npz")
        if np.isfinite(result.trajectory.q).all():
            save_png(_optimum_figure(name, problem, result.trajectory, spec), out / f"{name}.png")
    return ok


def _optimum_figure(name, problem, traj, spec):
    """The path with goal, headings and the system's bodies (left), each control and the energy balance (right)."""
    system = problem.disc.system
    fig, grid = _grid_figure(10.0, 5.6, system.n_u + 1, 2)
    path = fig.add_subplot(grid[:, 0])
    plot_path(traj, heading=spec.heading, goal=problem.q_goal, labels=system.names[:2],
              units=system.units, bodies=system.bodies, title=f"{name}: path", ax=path)
    right = [fig.add_subplot(grid[0, 1])]
    right += [fig.add_subplot(grid[i, 1], sharex=right[0]) for i in range(1, system.n_u + 1)]
    for ax in right[:-1]:
        ax.tick_params(labelbottom=False)
    plot_controls(traj, names=spec.control_names, units=system.units,
                  bounds=problem.control_bounds, axes=right[:-1], title="controls")
    right[-2].set_xlabel("")                      # t is labelled once, under the balance
    plot_energy_balance(problem.disc, traj, time_unit=system.units["t"], ax=right[-1],
                        title="energy balance (W: work of the controls)")
    return fig


def run_demo(args):
    """``dmoc demo``; returns 0, 1 when a DMOC solve failed (the rest is still written), 2
    when writing into ``--out`` failed (the summary computed so far is printed)."""
    out = arguments.output_folder("--out", args.out)
    lines = ["Dirac integrator, unforced motion against the closed-form solutions"]
    try:
        with staged_run(out, "demo") as stage:
            simulation_demo(stage, args.steps, lines)
            lines += ["", "DMOC: optimal control with the same step residual, replayed by "
                      "the simulator"]
            ok = optimization_demo(stage, args.opt_steps, lines)
            write_text(stage / "summary.txt", "\n".join(lines) + "\n")
    except OSError as err:  # disk full, file-size limit, folder removed
        print("\n".join(lines))
        raise UsageError("--out", f"writing into {str(out)!r} failed: {err.strerror or err}; "
                         f"nothing there was changed (the summary so far is above)") from None
    print("\n".join(lines))
    print(f"\nwrote {out / 'summary.txt'} and plots in {out}/")
    return 0 if ok else 1
