"""
A fan of knife-edge motion primitives on Dask
=============================================

A lattice of knife-edge motion primitives: rest-to-rest DMOC solves from (0, 0, 0) to
(1.5, y, theta) for 5 lateral offsets y in [-1, 1] and 5 goal headings theta in
[-pi/2, pi/2], in 3 s, minimizing the integral of the squared norm of u, solved as batches on dask.distributed.

Warm starts in waves: the straight primitive (y, theta) = (0, 0) is the seed (wave 0, the
default guess); wave d holds the primitives d grid cells away from it (Chebyshev distance),
each warm-started from the solved neighbour one cell closer to the seed. The 25 solves are
therefore 3 calls of `dmoc.batch.optimize_many` (1, 8 and 16 problems) on one cluster.
Each primitive is saved as ``motion_primitives/y{i}_theta{j}.npz`` (`Trajectory.save`), the
table as ``motion_primitives.csv``, and the fan of paths as ``motion_primitives.png``.

Run:  python examples/motion_primitives.py [--steps 100] [--out dmoc-output]
"""

import pathlib

import distributed
import numpy as np

from dmoc import OptimalControlProblem, discretize, systems
from dmoc.batch import optimize_many
from dmoc.cli import example_arguments

DISTANCE, DURATION = 1.5, 3.0
OFFSETS = np.linspace(-1.0, 1.0, 5)
HEADINGS = np.linspace(-np.pi / 2, np.pi / 2, 5)
SEED = (2, 2)  # grid cell (offset index, heading index) of the straight primitive


def primitive(disc, steps, i, j):
    """The OptimalControlProblem of grid cell (i, j): goal (DISTANCE, OFFSETS[i], HEADINGS[j])."""
    return OptimalControlProblem(disc, steps, q_start=[0.0, 0.0, 0.0],
                                 q_goal=[DISTANCE, OFFSETS[i], HEADINGS[j]])


def waves():
    """Lists of grid cells by Chebyshev distance from SEED, each cell with the neighbour one
    cell closer to SEED that warm-starts it (None for the seed)."""
    cells = [(i, j) for i in range(len(OFFSETS)) for j in range(len(HEADINGS))]
    distance = {c: max(abs(c[0] - SEED[0]), abs(c[1] - SEED[1])) for c in cells}
    return [[(c, None if d == 0 else tuple(int(a - np.sign(a - s)) for a, s in zip(c, SEED)))
             for c in cells if distance[c] == d] for d in range(max(distance.values()) + 1)]


def solve_lattice(steps, client):
    """{cell: OptimizationResult} of every primitive, solved wave by wave on `client`."""
    disc = discretize(systems.knife_edge(mass=1.0, inertia=1.0), DURATION / steps)
    solved = {}
    for wave in waves():
        problems = [primitive(disc, steps, *cell) for cell, _ in wave]
        guesses = [None if near is None else solved[near].trajectory for _, near in wave]
        for (cell, _), result in zip(wave, optimize_many(problems, guesses=guesses, client=client)):
            solved[cell] = result
    return solved


def draw_fan(solved, path):
    """Every primitive's path, coloured by its optimal cost (the colour bar gives the scale),
    with its final heading."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.6, 5.0), layout="constrained")
    ax = fig.add_subplot()
    costs = np.array([r.cost for r in solved.values()])
    scale = ScalarMappable(Normalize(costs.min(), costs.max()), colormaps["viridis"])
    for (cell, result), color in zip(solved.items(), scale.to_rgba(costs)):
        q = result.trajectory.q
        ax.plot(q[:, 0], q[:, 1], color=color, lw=1.2)
        ax.arrow(q[-1, 0], q[-1, 1], 0.15 * np.cos(q[-1, 2]), 0.15 * np.sin(q[-1, 2]),
                 color=color, head_width=0.04, length_includes_head=True)
    ax.plot(0, 0, "ko")
    units = systems.knife_edge().units["q"]
    ax.set(xlabel=f"x [{units[0]}]", ylabel=f"y [{units[1]}]", aspect="equal",
           title=f"knife-edge motion primitives ({len(solved)})")
    fig.colorbar(scale, ax=ax, shrink=0.85, label="optimal cost J = int |u|^2 dt")
    fig.savefig(path, dpi=100)


def main(steps=40, out="dmoc-output", client=None):
    out = pathlib.Path(out)
    (out / "motion_primitives").mkdir(parents=True, exist_ok=True)
    if client is None:
        with distributed.LocalCluster(threads_per_worker=1, dashboard_address=":0") as cluster, \
                distributed.Client(cluster) as own:
            solved = solve_lattice(steps, own)
    else:
        solved = solve_lattice(steps, client)
    rows = ["offset,heading,cost,iterations,status"]
    for (i, j), result in sorted(solved.items()):
        result.trajectory.save(out / "motion_primitives" / f"y{i}_theta{j}.npz")
        rows.append(f"{OFFSETS[i]:.6g},{HEADINGS[j]:.6g},{result.cost:.10g},"
                    f"{result.stats['iterations']},{result.status}")
    (out / "motion_primitives.csv").write_text("\n".join(rows) + "\n")
    draw_fan(solved, out / "motion_primitives.png")
    print("\n".join(rows))
    print(f"{sum(r.success for r in solved.values())}/{len(solved)} primitives solved, "
          f"{sum(r.stats['iterations'] for r in solved.values())} IPOPT iterations in all")
    return solved


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
