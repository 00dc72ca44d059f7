"""Command-line front end: ``dmoc demo`` simulates the built-in systems, solves the two DMOC
examples (knife-edge parking, rolling-disk steering) and writes a summary and plots. A thin layer over the
public API; it holds no mechanics of its own."""

import argparse
import pathlib
import sys

import numpy as np

from . import diagnostics, discretize, optimize, problems, simulate, systems
from .plotting import plot_path, plot_series, save_trajectory_plots

# Unforced demo runs: (name, system, its closed-form solution, q0, v0, final time).
_DEMOS = (
    ("knife_edge", systems.knife_edge(incline=0.2), 
     lambda t, q0, v0: systems.knife_edge_solution(t, q0, v0, incline=0.2),
     [0.0, 0.0, 0.0], [1.0, 0.0, 1.0], 10.0),
    ("rolling_disk", systems.rolling_disk(),
     lambda t, q0, v0: systems.rolling_disk_solution(t, q0, v0),
     [0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 1.0, 0.5], 10.0),
)


def simulation_demo(out, steps):
    """Simulate each demo system with both variants; return summary lines, save plots."""
    lines = [f"{'system':14s} {'variant':7s} {'steps':>6s} {'max |q - q_exact|':>18s} "
             f"{'max |omega_d|':>14s} {'max|E-E0|':>13s} {'time [s]':>9s}"]
    for name, system, exact, q0, v0, T in _DEMOS:
        disc = discretize(system, T / steps)
        for variant in ("+", "-"):
            res = simulate(disc, q0=q0, v0=v0, steps=steps, variant=variant)
            traj = res.trajectory
            q_exact, _ = exact(traj.t, np.asarray(q0), np.asarray(v0))
            E = diagnostics.energy(disc, traj)
            lines.append(
                f"{name:14s} {variant:7s} {steps:6d} {np.abs(traj.q - q_exact).max():18.3e} "
                f"{diagnostics.constraint_violation(disc, traj).max():14.3e} "
                f"{np.abs(E - E[0]).max():13.3e} {res.stats['wall_time']:9.4f}")
        fig = plot_path(traj, title=f"{name}: simulated path ({steps} steps)")
        fig.axes[0].plot(q_exact[:, 0], q_exact[:, 1], "k--", lw=0.8, label="exact")
        fig.axes[0].legend()
        fig.savefig(out / f"{name}_simulated_path.png", dpi=120)
        t_mid = (traj.t[:-1] + traj.t[1:]) / 2          # E is evaluated at step midpoints
        plot_series(t_mid, {"energy": E}, ylabel="E", title=f"{name}: energy").savefig(
            out / f"{name}_energy.png", dpi=120)
    return lines


def optimization_demo(out, steps):
    """Solve the two DMOC examples with both variants; return summary lines, save plots and
    the trajectory of each variant (the positions coincide, the momenta do not)."""
    lines = []
    for name, make in (("knife_edge_parking", problems.knife_edge_parking),
                       ("rolling_disk_steering", problems.rolling_disk_steering)):
        for variant, suffix in (("+", "plus"), ("-", "minus")):
            problem = make(steps, variant=variant)
            result = optimize(problem)
            figures = diagnostics.optimization_summary(problem, result)
            lines.append(diagnostics.format_summary(f"{name} (variant {variant}, N = {steps})", figures))
            result.trajectory.save(out / f"{name}_{suffix}.npz")
        save_trajectory_plots(result.trajectory, out, name)
    return lines


def example_arguments(description, argv=None):
    """Parse the options shared by the example scripts: ``--steps`` and ``--out``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--steps", type=int, default=100, help="DMOC steps (default: 100)")
    parser.add_argument("--out", default="dmoc-output", help="output folder (default: dmoc-output)")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error("--steps must be a positive integer")
    return args


def main(argv=None):
    """Entry point of the ``dmoc`` command."""
    parser = argparse.ArgumentParser(prog="dmoc", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="simulate and optimize the built-in systems; write a summary and plots")
    demo.add_argument("--out", default="dmoc-output", help="output folder (default: dmoc-output)")
    demo.add_argument("--steps", type=int, default=1000, help="simulation steps (default: 1000)")
    demo.add_argument("--opt-steps", type=int, default=100, help="DMOC steps (default: 100)")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.opt_steps < 1:
        parser.error("--steps and --opt-steps must be positive integers")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    lines = ["Dirac integrator, unforced motion against the closed-form solutions"]
    lines += simulation_demo(out, args.steps)
    lines += ["", "DMOC: optimal control with the same step residual, replayed by the simulator"]
    lines += optimization_demo(out, args.opt_steps)
    summary = "\n".join(lines)
    (out / "summary.txt").write_text(summary + "\n")
    print(summary)
    print(f"\nwrote {out / 'summary.txt'} and plots in {out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
