"""
An LC circuit: a degenerate Lagrangian, simulated and steered
=============================================================

An LC circuit, a degenerate Lagrangian: simulated against its closed form, then its
inductor charge steered by the voltage source with DMOC.

Inductor L_0 = 0.8, capacitors C_1 = 0.5 and C_2 = 1.5 in parallel (docs/degenerate.md).
The capacitor charges have no kinetic energy, so dL/dv is not invertible; the midpoint
rule's step equations still determine each step. First the free oscillation over five
periods: error against `lc_circuit_solution`, Kirchhoff's current law at every node, the
voltage law where the rule samples the capacitors, and the energy. Then DMOC: move the
charge q_L from 0 to 1 in 3 s, rest to rest, minimizing int u^2 dt over the source voltage
u, and replay the optimal voltages with the simulator. The energy balance of the optimum,
E - E_0 minus the work of the source, is zero to round-off: for the midpoint rule on this
quadratic Lagrangian with a constant constraint it is an identity (docs/stages/results.md).

Run:  python examples/lc_circuit.py [--steps 100] [--out dmoc-output]
"""

import pathlib

import numpy as np

import dmoc
from dmoc.cli import example_arguments
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.plotting import plot_controls, plot_energy_balance, plot_energy_error, plot_states
from dmoc.systems import lc_circuit, lc_circuit_solution

INDUCTANCE, CAPACITANCES = 0.8, (0.5, 1.5)
Q0, V0 = [0.1, 0.2, 0.6], [0.3, 0.075, 0.225]     # capacitor voltage 0.4, current 0.3
DURATION, CHARGE = 3.0, 1.0


def free_oscillation(steps):
    """Simulate five periods with `steps` steps per period; return the trajectory and its
    summary lines."""
    C1, C2 = CAPACITANCES
    period = 2 * np.pi * np.sqrt(INDUCTANCE * (C1 + C2))
    disc = dmoc.discretize(lc_circuit(INDUCTANCE, CAPACITANCES), period / steps)
    traj = dmoc.simulate(disc, q0=Q0, v0=V0, steps=5 * steps).trajectory
    exact, _ = lc_circuit_solution(traj.t, Q0, V0, inductance=INDUCTANCE, capacitances=CAPACITANCES)
    q, mid = traj.q, (traj.q[1:] + traj.q[:-1]) / 2
    E = dmoc.diagnostics.energy(disc, traj)
    lines = [f"free oscillation, {5 * steps} steps (h = {disc.h:.4g})",
             f"  max |q - q_exact|            {np.abs(q - exact).max():.3e}",
             f"  Kirchhoff current, nodes     {np.abs(np.diff(q[:, 0] - q[:, 1] - q[:, 2])).max():.3e}",
             f"  Kirchhoff voltage, midpoints {np.abs(mid[:, 1] / C1 - mid[:, 2] / C2).max():.3e}",
             f"  max |E - E_0|                {np.abs(E - E[0]).max():.3e} (E_0 = {E[0]:.6f})"]
    return disc, traj, exact, lines


def steer_charge(steps):
    """DMOC: q_L from 0 to CHARGE in DURATION, rest to rest, min int u^2."""
    C1, C2 = CAPACITANCES
    C = C1 + C2
    disc = dmoc.discretize(lc_circuit(INDUCTANCE, CAPACITANCES), DURATION / steps)
    problem = dmoc.OptimalControlProblem(disc, steps, q_start=[0, 0, 0],
                                         q_goal=[CHARGE, C1 / C * CHARGE, C2 / C * CHARGE])
    result = dmoc.optimize(problem)
    return result, format_summary(f"steer the charge, N = {steps}", optimization_summary(problem, result))


def main(steps=100, out="dmoc-output"):
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    disc, traj, exact, lines = free_oscillation(steps)
    result, summary = steer_charge(steps)
    text = "\n".join(lines + [summary])
    print(text)
    (out / "lc_circuit_summary.txt").write_text(text + "\n")
    names, units = disc.system.names, disc.system.units
    fig = plot_states(traj, names=names, units=units,
                      title="LC circuit: free oscillation (dashed: exact)")
    for ax, column in zip(fig.axes, exact.T):
        ax.plot(traj.t, column, "k--", lw=0.8)
    fig.savefig(out / "lc_circuit_charges.png")
    plot_energy_error(disc, traj, time_unit=units["t"], energy_unit="J",
                      title="LC circuit: energy error").savefig(out / "lc_circuit_energy.png")
    opt = result.trajectory
    plot_states(opt, names=names, units=units, title="LC circuit: steered charges").savefig(
        out / "lc_circuit_steering.png")
    plot_controls(opt, names=["source voltage"], units=units,
                  title="LC circuit: optimal voltage").savefig(out / "lc_circuit_controls.png")
    plot_energy_balance(disc, opt, time_unit=units["t"], energy_unit="J",
                        title="LC circuit: energy balance of the optimum (W: work of the source)"
                        ).savefig(out / "lc_circuit_balance.png")
    opt.save(out / "lc_circuit_steering.npz")
    return result


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
