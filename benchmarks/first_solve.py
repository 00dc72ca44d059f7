"""Benchmark: the least time to construct a built-in problem and to solve it from scratch
(construction plus `optimize`, dmoc's solver cache emptied before each), knife-edge parking
(A) and rolling-disk steering (B) at N = 25 and 100, minimum over `--repeat` fresh problems.
Run it under PYTHONPATH for two checkouts, alternating, to compare them:

    python benchmarks/first_solve.py [--repeat 25]
"""

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import dmoc  # noqa: E402
import dmoc.problems  # noqa: E402
from solver_cache import forget_solvers  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=25)
    args = parser.parse_args(argv)
    print(f"dmoc from {os.path.dirname(dmoc.__file__)}; load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()}")
    for name, make in (("A", dmoc.problems.knife_edge_parking), ("B", dmoc.problems.rolling_disk_steering)):
        for steps in (25, 100):
            construct, total = [], []
            for _ in range(args.repeat):
                forget_solvers()
                tic = time.perf_counter()
                problem = make(steps)
                built = time.perf_counter()
                result = dmoc.optimize(problem)
                construct.append(built - tic)
                total.append(time.perf_counter() - tic)
            print(f"{name}{steps}: construct {min(construct) * 1e3:.2f} ms, end-to-end "
                  f"{min(total) * 1e3:.2f} ms ({result.stats['iterations']} it)")


if __name__ == "__main__":
    main()
