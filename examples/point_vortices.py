"""
Point vortices: a Lagrangian linear in the velocities
=====================================================

Point vortices, a Lagrangian linear in the velocities: a pair against its rigid rotation,
and three vortices with their conserved quantities.

L = sum_i Gamma_i/2 (x_i ydot_i - y_i xdot_i) - H, H = 1/(4 pi) sum_{i<j} Gamma_i Gamma_j
log(abs(r_i - r_j)^2) (docs/degenerate.md). The pair Gamma = (1, 2) turns about its centre of
vorticity at Omega = (Gamma_1 + Gamma_2)/(2 pi d^2): ten turns with `--steps` steps per
turn, the rate measured from the simulation against the formula, the distance and the
centre of vorticity conserved to round-off. Three vortices (1, 2, -0.5) have no closed
form; their linear impulse sum Gamma_i r_i and angular impulse sum Gamma_i abs(r_i)^2 are
conserved to round-off (the midpoint rule is the implicit midpoint rule here, which keeps
linear and quadratic invariants), H up to a bounded error.

Run:  python examples/point_vortices.py [--steps 100] [--out dmoc-output]
"""

import pathlib

import numpy as np

import dmoc
from dmoc.cli import example_arguments
from dmoc.plotting import plot_path
from dmoc.systems import point_vortices, point_vortices_solution

PAIR, PAIR_Q0 = (1.0, 2.0), [1.0, 0.0, -0.5, 0.3]
TRIPLE, TRIPLE_Q0 = (1.0, 2.0, -0.5), [1.0, 0.0, -0.5, 0.3, 0.2, 1.2]


def pair(steps):
    """Ten turns of the pair with `steps` steps per turn; the trajectory and summary lines."""
    r0 = np.subtract(PAIR_Q0[:2], PAIR_Q0[2:])
    Omega = sum(PAIR) / (2 * np.pi * (r0 @ r0))
    disc = dmoc.discretize(point_vortices(PAIR), 2 * np.pi / Omega / steps)
    traj = dmoc.simulate(disc, q0=PAIR_Q0, v0=np.zeros(4), steps=10 * steps).trajectory
    exact, _ = point_vortices_solution(traj.t, PAIR_Q0, PAIR)
    r = traj.q[:, :2] - traj.q[:, 2:]
    angle = np.unwrap(np.arctan2(r[:, 1], r[:, 0]))
    centre = (PAIR[0] * traj.q[:, :2] + PAIR[1] * traj.q[:, 2:]) / sum(PAIR)
    distance = np.hypot(*r.T)
    return traj, [f"pair {PAIR}, {traj.steps} steps (h = {disc.h:.4g})",
                  f"  Omega: measured {(angle[-1] - angle[0]) / traj.t[-1]:.8f}, "
                  f"(Gamma_1 + Gamma_2)/(2 pi d^2) = {Omega:.8f}",
                  f"  max |q - q_exact|         {np.abs(traj.q - exact).max():.3e}",
                  f"  distance drift            {np.abs(distance - distance[0]).max():.3e}",
                  f"  centre of vorticity drift {np.abs(centre - centre[0]).max():.3e}"]


def triple(steps):
    """Three vortices over 10 * steps steps of 0.05; the trajectory and summary lines."""
    system = point_vortices(TRIPLE)
    traj = dmoc.simulate(dmoc.discretize(system, 0.05), q0=TRIPLE_Q0, v0=np.zeros(6),
                         steps=10 * steps).trajectory
    gamma, r = np.array(TRIPLE), traj.q.reshape(traj.q.shape[0], -1, 2)
    linear = np.einsum("i,kij->kj", gamma, r)
    angular = np.einsum("i,kij->k", gamma, r**2)
    H = -np.array(system.lagrangian.map(traj.q.shape[0])(traj.q.T, np.zeros_like(traj.q.T))).ravel()
    return traj, [f"three vortices {TRIPLE}, {traj.steps} steps (h = 0.05)",
                  f"  H drift                   {np.abs(H - H[0]).max():.3e}",
                  f"  linear impulse drift      {np.abs(linear - linear[0]).max():.3e}",
                  f"  angular impulse drift     {np.abs(angular - angular[0]).max():.3e}"]


def _plot_vortices(traj, units, circulations, title, path):
    """Each vortex's path in its own colour, labelled with its circulation."""
    fig = None
    for i, gamma in enumerate(circulations):
        fig = plot_path(traj, x=2 * i, y=2 * i + 1, units=units, color=f"C{i}",
                        name=f"vortex {i + 1}, Gamma = {gamma:g}", title=title,
                        ax=fig.axes[0] if fig else None)
    fig.savefig(path)


def main(steps=100, out="dmoc-output"):
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    pair_traj, pair_lines = pair(steps)
    triple_traj, triple_lines = triple(steps)
    text = "\n".join(pair_lines + triple_lines)
    print(text)
    (out / "point_vortices_summary.txt").write_text(text + "\n")
    units = point_vortices(PAIR).units
    _plot_vortices(pair_traj, units, PAIR, "vortex pair", out / "point_vortices_pair.png")
    _plot_vortices(triple_traj, point_vortices(TRIPLE).units, TRIPLE, "three vortices",
                   out / "point_vortices_triple.png")
    return pair_traj


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
