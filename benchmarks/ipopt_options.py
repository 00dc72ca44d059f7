"""Benchmark: IPOPT and MUMPS options on a warm re-solve (issue 25; docs/performance.md,
"The re-solve, sixth pass"), in one process, the option sets called in turn.

Rolling-disk steering (lobatto4, N = 11; `--problem knife`: knife-edge parking, lobatto3,
N = 28): one chain of warm raw compiled re-solves ``solve(problem.with_boundary(q_goal=g),
guess=previous, jit=True, options=...)`` per option set over `peers_resolve.py`'s goals,
`--repeat` cycles, the sets called in turn goal by goal with the one that goes first
turning. Per set: the median wall time and IPOPT's (``stats["ipopt_time"]``), the
iterations at each goal of the first cycle, whether x, lam_g and the cost have the bits
of dmoc's defaults ("base", first), and the largest relative difference of the cost and
the largest difference of x from them.

    python benchmarks/ipopt_options.py [--repeat 40] [--problem disk|knife]
        [--sets '{"name": {IPOPT options}, ...}']
"""

import argparse
import json
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import peers_resolve as peers  # noqa: E402
from dmoc.optimal_control.solver.solving import solve  # noqa: E402

PROBLEMS = {"disk": ("rolling disk", "lobatto4", 11), "knife": ("knife edge", "lobatto3", 28)}
SETS = {"mumps_mem_percent 100": {"mumps_mem_percent": 100},
        "min_refinement_steps 0": {"min_refinement_steps": 0},
        "mumps_pivtol 1e-8": {"mumps_pivtol": 1e-8},
        "QAMD (mumps_pivot_order 6)": {"mumps_pivot_order": 6},
        "no NLP scaling (nlp_scaling_method none)": {"nlp_scaling_method": "none"}}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=40, help="cycles over the goals")
    parser.add_argument("--problem", choices=PROBLEMS, default="disk")
    parser.add_argument("--sets", type=json.loads, default=SETS, help="JSON {name: options}")
    args = parser.parse_args(argv)
    name, rule, N = PROBLEMS[args.problem]
    print(f"{name}, {rule}, N = {N}; load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    sets = {"base": {}, **args.sets}
    targets = peers.goals(name, 5)
    problem = peers.dmoc_problem(name, N, rule, targets[0])
    moved = [peers.moved(problem, name, g) for g in list(targets[1:]) + [targets[0]]]
    start = solve(problem, jit=True)
    previous = {k: start for k in sets}
    wall, ipopt_time, first = ({k: [] for k in sets} for _ in range(3))
    names, turn = list(sets), 0
    for cycle in range(args.repeat):
        for i, goal in enumerate(moved):
            for k in names[turn % len(names):] + names[:turn % len(names)]:
                tic = time.perf_counter()
                previous[k] = solve(goal, guess=previous[k], jit=True, options=sets[k])
                wall[k].append(time.perf_counter() - tic)
                ipopt_time[k].append(previous[k].stats["ipopt_time"])
                if cycle == 0:
                    first[k].append(previous[k])
            turn += 1
    print(f"\n| option set | ms | IPOPT ms | iterations | same bits | max dJ/J | max dx |\n|---|---:|---:|---|---|---:|---:|")
    for k in sets:
        base = first["base"]
        same = all(np.array_equal(a.x, b.x) and np.array_equal(a.lam_g, b.lam_g) and a.cost == b.cost
                   for a, b in zip(first[k], base))
        dJ = max(abs(a.cost - b.cost) / abs(b.cost) for a, b in zip(first[k], base))
        dx = max(float(np.abs(a.x - b.x).max()) for a, b in zip(first[k], base))
        print(f"| {k} | {np.median(wall[k]) * 1e3:.3f} | {np.median(ipopt_time[k]) * 1e3:.3f} | "
              f"{[r.stats['iterations'] for r in first[k]]} | {same} | {dJ:.1e} | {dx:.1e} |")
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
