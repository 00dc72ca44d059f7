"""Benchmark: 64 knife-edge parking problems (dmoc.problems.parking_goals) solved serially
in-process with ``dmoc.optimize`` against ``dmoc.batch.optimize_many`` on a LocalCluster of
1 and of 2 single-threaded worker processes.

The problems are built once, before any timing. For each cluster, **startup** is starting
it plus a warm-up batch of one solve per worker (the workers import dmoc and CasADi);
**wall** is then one ``optimize_many`` call on the running cluster, best of `--repeat`.
Speed-ups are serial wall / batch wall, and 1-worker wall / 2-worker wall. The last column
is the largest |cost - serial cost| over the 64 problems; ``shipped`` is the mean size of
one pickled problem, the bulk of what is sent per task.

    python benchmarks/batch.py                 # N = 20 and N = 100
    python benchmarks/batch.py --steps 200
"""

import argparse
import os
import platform
import time

# One BLAS thread per process: the workers, not BLAS threads, share the cores.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import distributed  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.problems import knife_edge_parking, parking_goals  # noqa: E402


def best_of(repeat, run):
    """(smallest wall time, last value) of `repeat` calls of run()."""
    times, value = [], None
    for _ in range(repeat):
        tic = time.perf_counter()
        value = run()
        times.append(time.perf_counter() - tic)
    return min(times), value


def on_cluster(problems, workers, repeat):
    """(startup seconds, best wall seconds, costs) of optimize_many on `workers` workers."""
    tic = time.perf_counter()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        batch.optimize_many(problems[:workers], client=client, progress=False)
        startup = time.perf_counter() - tic
        wall, results = best_of(repeat, lambda: batch.optimize_many(problems, client=client,
                                                                     progress=False))
    assert all(r.success for r in results), [r.status for r in results if not r.success]
    return startup, wall, np.array([r.cost for r in results])


def table(steps, repeat):
    problems = [knife_edge_parking(steps, goal=goal) for goal in parking_goals()]
    shipped = np.mean([len(batch.pack_problem(p)) for p in problems])
    serial_wall, serial = best_of(repeat, lambda: [dmoc.optimize(p) for p in problems])
    serial_costs = np.array([r.cost for r in serial])
    rows = [("serial", "-", "-", serial_wall, 0.0)]
    for workers in (1, 2):
        startup, wall, costs = on_cluster(problems, workers, repeat)
        rows.append(("cluster", workers, f"{startup:.2f}", wall, np.abs(costs - serial_costs).max()))
    lines = [f"N = {steps}: 64 problems, {sum(r.stats['iterations'] for r in serial)} IPOPT "
             f"iterations in all, shipped {shipped / 1e3:.0f} kB per problem",
             f"{'run':8s} {'workers':>7s} {'startup s':>10s} {'wall s':>8s} {'vs serial':>10s} "
             f"{'vs 1 worker':>12s} {'max |dcost|':>12s}", "-" * 72]
    one_worker_wall = rows[1][3]
    for name, workers, startup, wall, dcost in rows:
        lines.append(f"{name:8s} {workers!s:>7s} {startup:>10s} {wall:8.3f} "
                     f"{serial_wall / wall:10.2f} {one_worker_wall / wall:12.2f} {dcost:12.1e}")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, nargs="+", default=[20, 100])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    print(f"python {platform.python_version()}, casadi {ca.__version__}, dask.distributed "
          f"{distributed.__version__}, {os.cpu_count()} CPUs, load average "
          + "%.2f %.2f %.2f" % os.getloadavg())
    for steps in args.steps:
        print(table(steps, args.repeat) + "\n")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
