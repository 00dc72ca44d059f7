"""Benchmark: `dmoc.batch` on a running 2-worker cluster against the serial loop a user
would otherwise write, both timed in the same round (docs/performance.md, `batch.py`).

- **optimize**: `count` knife-edge parking problems at N = `--steps`, built as a user
  builds them, each its own object: ``[OptimalControlProblem(discretize(knife_edge(), h),
  N, q_start=(0, 0, 0), q_goal=(0, y, 0.1)) for y in ...]``; the serial loop
  ``[dmoc.optimize(p) for p in problems]`` against ``optimize_many(problems,
  client=cluster)``.
- **simulate**: `count` knife-edge runs of `--sim-steps` steps (v0 = (c, 0, 1), h = 0.01),
  the serial loop ``[dmoc.simulate(disc, **run) for run in runs]`` against
  ``simulate_many(disc, runs, client=cluster)``.

Before the timed rounds one untimed round of every tenth item warms both sides (the
serial process's and each worker's solvers and compiled steps). Each of `--repeat` rounds
times the serial loop, then the batch, so that both see the same load; the speed-up of
each round is serial wall / batch wall (higher is better), printed with the load average
(the machine has to be otherwise idle for the ratio to mean anything: 2 workers want 2
free cores). "cpu bound" is 2 x serial CPU / batch CPU (this process: client, scheduler,
nannies; and the workers): the speed-up on 2 free cores if CPU were the only limit, which
other jobs on the machine inflate much less than the wall times. ``max |diff|`` compares
the batch's costs (trajectories) with the serial ones.

    python benchmarks/batch.py                        # 1000 items, N = 20, 1000 steps, 3 rounds
    python benchmarks/batch.py --count 8 --sim-steps 20 --repeat 1    # smallest (a test runs it)
"""

import argparse
import os
import platform
import resource
import time

# One BLAS thread per process: the workers, not BLAS threads, share the cores.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import distributed  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402

WORKERS = 2


def parking_problems(count, steps, duration=4.0):
    """`count` knife-edge parking problems at N = `steps`, each built on its own."""
    h = duration / steps
    return [dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), h), steps,
                                       q_start=[0.0, 0.0, 0.0], q_goal=[0.0, y, 0.1])
            for y in np.linspace(0.2, 2.0, count)]


def knife_edge_runs(count, steps):
    """(Discretization, runs): the knife edge at h = 0.01, `count` runs of `steps` steps."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.01)
    return disc, [{"q0": [0.0, 0.0, 0.0], "v0": [c, 0.0, 1.0], "steps": steps}
                  for c in np.linspace(0.5, 2.0, count)]


def cpu_seconds():
    """This process's CPU seconds, all threads (the client, and a LocalCluster's scheduler
    and nannies)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def timed(run, cluster=None):
    """(wall seconds, CPU seconds, value) of run(): the CPU of this process, plus that of
    the `cluster`'s workers when one is given."""
    def cpu():
        return cpu_seconds() + (sum(cluster.client.run(cpu_seconds).values()) if cluster else 0.0)
    tic, spent = time.perf_counter(), cpu()
    value = run()
    wall = time.perf_counter() - tic
    return wall, cpu() - spent, value


def rounds(serial, batched, compare, repeat, cluster):
    """[(serial wall, serial CPU, batch wall, batch CPU, max |diff|)] of `repeat` rounds,
    after one warm-up round of every tenth item."""
    serial(10), batched(10)
    found = []
    for _ in range(repeat):
        serial_wall, serial_cpu, expected = timed(lambda: serial(1))
        wall, cpu, results = timed(lambda: batched(1), cluster)
        assert all(r.success for r in results), {r.status for r in results if not r.success}
        found.append((serial_wall, serial_cpu, wall, cpu, compare(results, expected)))
    return found


def optimize_rounds(cluster, count, steps, repeat):
    problems = parking_problems(count, steps)
    return rounds(lambda every: [dmoc.optimize(p) for p in problems[::every]],
                  lambda every: batch.optimize_many(problems[::every], client=cluster, progress=False),
                  lambda a, b: max(abs(x.cost - y.cost) for x, y in zip(a, b)), repeat, cluster)


def simulate_rounds(cluster, count, steps, repeat):
    disc, runs = knife_edge_runs(count, steps)
    return rounds(lambda every: [dmoc.simulate(disc, **run) for run in runs[::every]],
                  lambda every: batch.simulate_many(disc, runs[::every], client=cluster, progress=False),
                  lambda a, b: max(np.abs(x.trajectory.q - y.trajectory.q).max() for x, y in zip(a, b)),
                  repeat, cluster)


def report(label, found):
    """Print each round and the spread; the speed-ups (serial wall / batch wall)."""
    ratios = [serial / wall for serial, _, wall, _, _ in found]
    for k, (serial, serial_cpu, wall, cpu, diff) in enumerate(found):
        print(f"{label:30s} round {k + 1}: serial {serial:6.2f} s, batch {wall:6.2f} s, "
              f"speed-up {serial / wall:4.2f}, cpu bound {WORKERS * serial_cpu / cpu:4.2f}, "
              f"max |diff| {diff:.1e}, load {os.getloadavg()[0]:.2f}")
    print(f"{label:30s} speed-up min {min(ratios):.2f}, median {np.median(ratios):.2f}, "
          f"max {max(ratios):.2f}")
    return ratios


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=1000, help="items per batch (default 1000)")
    parser.add_argument("--steps", type=int, default=20, help="N of the parking problems")
    parser.add_argument("--sim-steps", type=int, default=1000, help="steps of each run")
    parser.add_argument("--repeat", type=int, default=3, help="timed rounds (default 3)")
    parser.add_argument("--only", choices=("optimize", "simulate"), nargs="+",
                        default=("optimize", "simulate"), help="rows to run")
    args = parser.parse_args(argv)
    print(f"python {platform.python_version()}, dask.distributed {distributed.__version__}, "
          f"{os.cpu_count()} CPUs, {WORKERS} workers x 1 thread, load average "
          "%.2f %.2f %.2f" % os.getloadavg())
    found = {}
    with batch.Cluster(workers=WORKERS) as cluster:
        if "optimize" in args.only:
            found["optimize"] = report(f"optimize {args.count} at N = {args.steps}",
                                       optimize_rounds(cluster, args.count, args.steps, args.repeat))
        if "simulate" in args.only:
            found["simulate"] = report(f"simulate {args.count} x {args.sim_steps} steps",
                                       simulate_rounds(cluster, args.count, args.sim_steps, args.repeat))
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())
    return found


if __name__ == "__main__":
    main()
