"""Benchmark: how DMOC's build and solve times grow with N, against the mapped trapezoidal
collocation of benchmarks/collocation.py, knife-edge parallel parking (problem A of
dmoc_vs_collocation.py; dmoc defaults: MX graph, midpoint rule, variant "+").

For each N: build (discretization and problem construction + nlpsol creation, the first
solve of that structure; the system, like the trapezoid's ODE Function, is built before
the clock starts), solve (the IPOPT call), iterations, and for dmoc the size of the NLP
and the build/solve ratio. Then the log-log slope of build + solve over N, least squares over
all N of the run. Best of `--repeat`; each dmoc repeat creates its solver anew. The solves are
not judged (``check=False``): the verdict is in neither time, and the warm-up's N = 10 fails it.

    python benchmarks/scaling.py                      # N = 200 ... 10^4 (about 2 min)
    python benchmarks/scaling.py --steps 200 1000     # chosen N
"""

import argparse
import os
import platform
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import collocation  # noqa: E402
import dmoc  # noqa: E402

STEPS = (200, 500, 1000, 2000, 5000, 10000)


def dmoc_run(N):
    """(build s, solve s, iterations, NLP variables, constraints) of one fresh DMOC solve."""
    dmoc.clear_caches("solvers", "row_sums")         # no solver reuse between repeats
    system = dmoc.systems.knife_edge(mass=1.0, inertia=1.0)    # before the clock, as the
    tic = time.perf_counter()                                   # trapezoid's ODE Function is
    disc = dmoc.discretize(system, 4.0 / N, "midpoint")
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0.0, 0.0, 0.0], q_goal=[0.0, 1.0, 0.0])
    construct = time.perf_counter() - tic
    res = dmoc.optimize(problem, check=False)          # the verdict is in neither time
    return (construct + res.stats["build_time"], res.stats["solve_time"], res.stats["iterations"],
            problem.x_layout.size, problem.g_layout.size)


def trapezoid_run(N):
    r = collocation.solve(collocation.knife_edge_problem(), N, "trapezoid")
    if not r.success:
        raise RuntimeError(r.status)
    return r.construct_time + r.nlpsol_time, r.solve_time, r.iterations, r.n_variables, r.n_constraints


def best(repeat, run, N):
    runs = [run(N) for _ in range(repeat)]
    return (min(r[0] for r in runs), min(r[1] for r in runs)) + runs[-1][2:]


def slope(steps, seconds):
    """Least-squares slope of log(seconds) over log(steps)."""
    return float(np.polyfit(np.log(steps), np.log(seconds), 1)[0])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=2, help="solves per N; best is kept (default 2)")
    parser.add_argument("--steps", type=int, nargs="+", default=STEPS)
    args = parser.parse_args(argv)
    print(f"dmoc from {os.path.dirname(dmoc.__file__)}; python {platform.python_version()}, "
          f"casadi {ca.__version__}; load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    dmoc_run(10), trapezoid_run(10)                     # load IPOPT and MUMPS once
    head = (f"{'method':<6}{'N':>7}{'vars':>8}{'cons':>8}{'build s':>10}{'solve s':>10}{'it':>4}"
            f"{'build/solve':>13}{'total/trap':>12}")
    print(head + "\n" + "-" * len(head))
    totals = {"dmoc": [], "trap": []}
    for N in args.steps:
        rows = {"dmoc": best(args.repeat, dmoc_run, N), "trap": best(args.repeat, trapezoid_run, N)}
        for name, (build, solve, it, nx, ng) in rows.items():
            totals[name].append(build + solve)
            print(f"{name:<6}{N:>7}{nx:>8}{ng:>8}{build:>10.4f}{solve:>10.4f}{it:>4}"
                  f"{build / solve:>13.2f}{(build + solve) / sum(rows['trap'][:2]):>12.2f}")
    for name, seconds in totals.items():
        print(f"{name}: log-log slope of build + solve over N = {args.steps[0]} ... {args.steps[-1]}: "
              f"{slope(args.steps, seconds):.2f}")
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
