"""Benchmark: where a DMOC build goes, on the parking problems of dmoc_vs_collocation.py
(A knife edge, B rolling disk; midpoint rule, variant "+").

For each problem and N, the minimum over `--repeat` builds of:

- construct: `discretize` + `OptimalControlProblem` (windows, scales, bounds, terms);
- assembly: ``problem.separable.derivatives()`` (gradient, Jacobian, Hessian);
- rest: the rest of ``stats["build_time"]`` (tolerances, nlpsol creation);
- index floor: only passing the final sparsity patterns and one nonzero map per matrix
  into CasADi (``ca.Sparsity`` and ``x[list]``), the part of the assembly that no
  Python-side implementation avoids;

and the solve time (also the minimum), and build / solve. The system is built once,
before the clock starts (as the baselines' ODE Function is). The solves are not judged
(``check=False``): the verdict is outside both times, and the warm-up's coarse grid
(N = 10) fails it (under_resolved).

    python benchmarks/build_split.py
    PYTHONPATH=/path/to/other/checkout python benchmarks/build_split.py   # compare checkouts
"""

import argparse
import os
import platform
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from solver_cache import forget_solvers  # noqa: E402

PROBLEMS = {
    "A": (lambda: dmoc.systems.knife_edge(mass=1.0, inertia=1.0),
          {"q_start": [0.0, 0.0, 0.0], "q_goal": [0.0, 1.0, 0.0]}),
    "B": (dmoc.systems.rolling_disk,
          {"q_start": [0.0, 0.0, 0.0, 0.0], "q_goal": [1.0, 1.0, None, np.pi / 2]}),
}


def index_floor(derivatives):
    """Seconds to pass the three final patterns and a nonzero map of each into CasADi."""
    patterns = [derivatives["nlp_grad_f"].sparsity_out(1), derivatives["nlp_jac_g"].sparsity_out(1),
                derivatives["nlp_hess_l"].sparsity_out(0)]
    lists = [(s.size1(), s.size2(), s.colind(), s.row()) for s in patterns]
    x = ca.MX.sym("x", max(len(row) for *_, row in lists))
    tic = time.perf_counter()
    for n1, n2, colind, row in lists:
        ca.Sparsity(n1, n2, list(colind), list(row))
        x[list(range(len(row)))]
    return time.perf_counter() - tic


def split(label, steps, repeat):
    """(construct, assembly, rest, index floor, solve) in seconds, each the minimum over
    `repeat` builds and solves."""
    make_system, boundary = PROBLEMS[label]
    system = make_system()
    runs = []
    for _ in range(repeat):
        forget_solvers()                       # every repeat builds its solver anew
        tic = time.perf_counter()
        problem = dmoc.OptimalControlProblem(dmoc.discretize(system, 4.0 / steps, "midpoint"),
                                             steps, variant="+", **boundary)
        construct = time.perf_counter() - tic
        tic = time.perf_counter()
        derivatives = problem.separable.derivatives()
        assembly = time.perf_counter() - tic
        result = dmoc.optimize(problem, check=False)
        runs.append((construct, assembly, result.stats["build_time"], index_floor(derivatives),
                     result.stats["solve_time"]))
    return tuple(min(column) for column in zip(*runs))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=15, help="builds per row; minima kept (default 15)")
    parser.add_argument("--steps", type=int, nargs="+", default=(50, 1000))
    args = parser.parse_args(argv)
    print(f"dmoc from {os.path.dirname(dmoc.__file__)}; python {platform.python_version()}, "
          f"casadi {ca.__version__}; load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    split("A", 10, 2)                          # load IPOPT and MUMPS once
    head = (f"{'problem':<8}{'N':>6}{'construct ms':>14}{'assembly ms':>13}{'rest ms':>9}"
            f"{'build ms':>10}{'index floor ms':>16}{'solve ms':>10}{'build/solve':>13}")
    print(head + "\n" + "-" * len(head))
    for steps in args.steps:
        for label in PROBLEMS:
            construct, assembly, rest, floor, solve = split(label, steps, args.repeat)
            build = construct + assembly + rest
            print(f"{label:<8}{steps:>6}{construct * 1e3:>14.2f}{assembly * 1e3:>13.2f}{rest * 1e3:>9.2f}"
                  f"{build * 1e3:>10.2f}{floor * 1e3:>16.2f}{solve * 1e3:>10.1f}{build / solve:>13.2f}")
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
