"""Benchmark: `dmoc.batch` on a 2-worker cluster against the serial in-process loop a user
would otherwise write, timed in the same run (docs/performance.md, `batch.py`).

- **optimize**: `count` knife-edge parking problems (goals (0, y, 0.1), y from 0.2 to 2.0,
  each ``base.with_boundary(q_goal=...)``) at each N of `--steps`: the serial loop of
  ``dmoc.optimize`` on the kept solver (built before timing) against ``optimize_many`` on
  a `dmoc.batch.Cluster` of 2 single-threaded workers already running and warmed up: one
  small batch of the same N (2 items per worker) solved before timing builds each
  worker's solver and the verdict's replay step. At the first N also the
  cluster's start included: starting a Cluster, the batch (no warm-up), closing it.
- **simulate**: `count` knife-edge runs of `--sim-steps` steps (v0 = (c, 0, 1)), serial
  ``dmoc.simulate`` against ``simulate_many``, both in compiled C (``jit=True``; the
  virtual machine where there is no C compiler), the step built before timing; then
  ``simulate_many(keep="final")``, which returns the last knot of each run only, against
  the same serial loop; and "in one process, packed": the worker's path without Dask, the
  same runs with ``throw=False`` as one chunk pickled and unpickled as it travels
  (`dmoc.batch.packing`), which tells the cost of packing from the parallel speed-up;
  "in one process, lockstep": the same with the runs in lockstep, as a worker's task
  steps them (`dmoc.simulation.lockstep`); "... through shared memory": the same in chunks
  of 125 runs through `dmoc.batch.sharing`, written and read back in this process, as a
  worker on the client's machine sends them.
- **overhead**: an empty problem (N = 3, start = goal at rest: a few IPOPT iterations on 31 variables), serial
  and on the cluster: seconds per item, and the worker-seconds a batch adds per item,
  2 x batch - serial (its cost of shipping, scheduling and collecting).

Speed-ups are serial wall / batch wall (higher is better); ``max |dcost|`` compares the
costs with the serial ones. The machine must be otherwise idle for the 2-worker ratios to
mean anything: the load average is printed before and after. "cpu bound" is
2 x serial CPU / batch CPU, the CPU seconds of this process (client, scheduler, nannies)
and of the workers over the batch: the speed-up on 2 free cores if CPU were the only
limit, which other jobs on the machine inflate much less than the wall times.

    python benchmarks/batch.py                 # 1000 problems at N = 20, 100, 400; 1000 runs
    python benchmarks/batch.py --quick         # 100 problems at N = 20, 100; 100 runs
    python benchmarks/batch.py --only simulate --repeat 5   # the simulate rows, medians of 5
"""

import argparse
import os
import pickle
import platform
import resource
import time

# One BLAS thread per process: the workers, not BLAS threads, share the cores.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import distributed  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.batch import sharing  # noqa: E402
from dmoc.batch.packing import PackedResults  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402
from dmoc.simulation.lockstep import simulate_runs  # noqa: E402
from knife_runs import knife_edge_runs  # noqa: E402

WORKERS = 2


def cpu_seconds():
    """This process's CPU seconds, all threads (the client, and a LocalCluster's scheduler
    and nannies)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def timed(run, cluster=None):
    """(wall seconds, CPU seconds, value) of run(): the CPU of this process, plus that of
    the `cluster`'s workers when one is given."""
    workers = (lambda: sum(cluster.client.run(cpu_seconds).values())) if cluster else (lambda: 0.0)
    tic, cpu = time.perf_counter(), cpu_seconds() + workers()
    value = run()
    wall = time.perf_counter() - tic
    return wall, cpu_seconds() + workers() - cpu, value


def parking(steps, count):
    base = knife_edge_parking(steps)
    return [base.with_boundary(q_goal=[0.0, y, 0.1]) for y in np.linspace(0.2, 2.0, count)]


def costs(results):
    assert all(r.success for r in results), [r.status for r in results if not r.success]
    return np.array([r.cost for r in results])


def optimize_row(cluster, steps, count):
    """(serial wall, serial CPU, batch wall, batch CPU, max |dcost|) of `count` parking
    problems at N = steps."""
    problems = parking(steps, count)
    dmoc.optimize(problems[0])                                        # the kept solver
    serial_wall, serial_cpu, serial = timed(lambda: [dmoc.optimize(p) for p in problems])
    batch.optimize_many(problems[:2 * WORKERS], client=cluster, progress=False)   # warm-up
    wall, cpu, results = timed(lambda: batch.optimize_many(problems, client=cluster,
                                                           progress=False), cluster)
    return serial_wall, serial_cpu, wall, cpu, np.abs(costs(results) - costs(serial)).max()


def with_start(steps, count):
    """Wall seconds of starting a Cluster, `count` parking problems on it, and closing it."""
    problems = parking(steps, count)

    def run():
        with batch.Cluster(workers=WORKERS) as cluster:
            return batch.optimize_many(problems, client=cluster, progress=False)
    wall, _, results = timed(run)
    costs(results)
    return wall


def simulate_rows(cluster, steps, count, repeat=1):
    """(label, serial wall, serial CPU, batch wall, batch CPU, max |dq|) of `count`
    knife-edge runs of `steps` steps, for ``keep="trajectory"`` and ``keep="final"``
    (compared with the last knot of the serial runs): medians of `repeat` rounds, each
    timing the serial loop and then each batch, so that both see the same load."""
    disc, runs = knife_edge_runs(count, steps)
    dmoc.simulate(disc, **runs[0])
    for keep in ("trajectory", "final"):
        batch.simulate_many(disc, runs[:2 * WORKERS], keep=keep, client=cluster, progress=False)
    packed_in_process(disc, runs)     # as on a worker after its first chunk: memory reused
    packed_in_process(disc, runs, simulate_runs)
    packed_in_process(disc, runs, simulate_runs, shared=True)
    times = {name: [] for name in ("serial", "trajectory", "final", "packed", "lockstep", "shared")}
    dq = dict.fromkeys(times, 0.0)
    for _ in range(repeat):
        wall, cpu, serial = timed(lambda: [dmoc.simulate(disc, **run) for run in runs])
        times["serial"].append((wall, cpu))
        for keep in ("trajectory", "final"):
            wall, cpu, results = timed(lambda: batch.simulate_many(
                disc, runs, keep=keep, client=cluster, progress=False), cluster)
            times[keep].append((wall, cpu))
            dq[keep] = max(dq[keep], *(np.abs(a.trajectory.q - b.trajectory.q[-len(a.trajectory.q):]).max()
                                       for a, b in zip(results, serial)))
        for name, simulated in (("packed", None), ("lockstep", simulate_runs),
                                ("shared", simulate_runs)):
            wall, cpu, results = timed(lambda: packed_in_process(disc, runs, simulated,
                                                                 name == "shared"))
            times[name].append((wall, cpu))
            dq[name] = max(dq[name], *(np.abs(a.trajectory.q - b.trajectory.q).max()
                                       for a, b in zip(results, serial)))
    median = {k: np.median(np.array(v), axis=0) for k, v in times.items()}
    serial_wall, serial_cpu = median["serial"]
    return [(f"simulate {count} x {steps} steps", serial_wall, serial_cpu, *median["trajectory"],
             dq["trajectory"]),
            ('  keep="final"', serial_wall, serial_cpu, *median["final"], dq["final"]),
            # one process, one core: its "cpu bound" column is serial CPU / its CPU
            ("  in one process, packed", serial_wall, serial_cpu, median["packed"][0],
             WORKERS * median["packed"][1], dq["packed"]),
            ("  in one process, lockstep", serial_wall, serial_cpu, median["lockstep"][0],
             WORKERS * median["lockstep"][1], dq["lockstep"]),
            ("  ... through shared memory", serial_wall, serial_cpu, median["shared"][0],
             WORKERS * median["shared"][1], dq["shared"])]


def packed_in_process(disc, runs, simulated=None, shared=False):
    """The runs as a worker's task makes them (``throw=False``; one by one, or by
    `simulated`, e.g. `simulate_runs`), as one chunk pickled and unpickled with
    out-of-band buffers, as Dask moves it; with `shared`, in chunks of 125 runs through
    shared memory (`dmoc.batch.sharing`) as a worker on the client's machine sends them."""
    buffers = []
    results = (simulated(disc, runs) if simulated is not None
               else [dmoc.simulate(disc, **run, throw=False) for run in runs])
    if not shared:
        data = pickle.dumps(PackedResults(results), protocol=5, buffer_callback=buffers.append)
        return pickle.loads(data, buffers=buffers)
    with sharing.Exchange() as share:
        return [result for i in range(0, len(results), 125)
                for result in pickle.loads(pickle.dumps(PackedResults(results[i:i + 125], share)))]


def overhead_row(cluster, count):
    """(serial s/item, batch s/item, added worker-seconds per item) of an empty problem."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    problems = [dmoc.OptimalControlProblem(disc, 3, q_start=[0, 0, 0], q_goal=[0, 0, 0])] * count
    dmoc.optimize(problems[0])
    serial_wall, _, _ = timed(lambda: [dmoc.optimize(p) for p in problems])
    batch.optimize_many(problems[:2 * WORKERS], client=cluster, progress=False)
    wall, _, results = timed(lambda: batch.optimize_many(problems, client=cluster, progress=False))
    costs(results)
    return serial_wall / count, wall / count, (WORKERS * wall - serial_wall) / count


def line(label, serial_wall, serial_cpu, wall, cpu, diff):
    """A row of the table; "cpu bound" is the speed-up if the batch's CPU (client,
    scheduler and workers) were the only limit on WORKERS free cores, WORKERS x serial CPU
    / batch CPU, which the machine's other jobs inflate much less than the wall times."""
    return (f"{label:28s} {serial_wall:9.2f} {wall:9.2f} {serial_wall / wall:9.2f} "
            f"{WORKERS * serial_cpu / cpu:10.2f} {diff:11.1e}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="100 items, N = 20 and 100")
    parser.add_argument("--count", type=int, help="items per row (default 1000, quick 100)")
    parser.add_argument("--steps", type=int, nargs="+", help="N of the parking rows")
    parser.add_argument("--sim-steps", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=1,
                        help="rounds of the simulate rows (medians; default 1)")
    parser.add_argument("--only", choices=("optimize", "simulate", "overhead"), nargs="+",
                        default=("optimize", "simulate", "overhead"), help="rows to run")
    args = parser.parse_args(argv)
    count = args.count or (100 if args.quick else 1000)
    steps = args.steps or ([20, 100] if args.quick else [20, 100, 400])
    print(f"python {platform.python_version()}, casadi {ca.__version__}, dask.distributed "
          f"{distributed.__version__}, {os.cpu_count()} CPUs, {WORKERS} workers x 1 thread, "
          "load average %.2f %.2f %.2f" % os.getloadavg())
    print(f"{'row':28s} {'serial s':>9s} {'batch s':>9s} {'speed-up':>9s} {'cpu bound':>10s} "
          f"{'max |diff|':>11s}")
    print("-" * 81)
    started = with_start(steps[0], count) if "optimize" in args.only else None
    with batch.Cluster(workers=WORKERS) as cluster:
        for k, N in enumerate(steps if "optimize" in args.only else ()):
            serial_wall, *row = optimize_row(cluster, N, count)
            print(line(f"optimize {count} at N = {N}", serial_wall, *row))
            if k == 0:
                print(f"{'  with the cluster start':28s} {serial_wall:9.2f} {started:9.2f} "
                      f"{serial_wall / started:9.2f}")
        for row in simulate_rows(cluster, args.sim_steps, count, args.repeat) if "simulate" in args.only else ():
            print(line(*row))
        if "overhead" in args.only:
            serial_item, batch_item, added = overhead_row(cluster, count)
            print(f"\nempty problem: serial {serial_item * 1e3:.2f} ms/item, batch "
                  f"{batch_item * 1e3:.2f} ms/item on {WORKERS} workers, overhead "
                  f"{added * 1e3:.2f} worker-ms/item")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
