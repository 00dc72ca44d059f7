"""Benchmark: runs in lockstep (`dmoc.simulation.lockstep.simulate_runs`) against the serial
loop ``[dmoc.simulate(disc, **run, throw=False) for run in runs]``, interleaved in one
process (docs/performance.md, "Sixth: runs in lockstep").

Each round times the serial loop, then the same runs in lockstep, then each part of a
run alone (the checks and start of all runs, `prepare_runs`; the steps one run at a time
and in lockstep, group by group as `simulate_runs` makes them; the steps in lockstep with
each group's runs concluded together, `conclude_group`, as `simulate_runs` does, with the
trajectory's last knot only too; and `conclude`'s trajectory and verdict run by run, with
the last knot only too, as ``keep="final"``), on knife-edge runs of `--steps` steps
(v0 = (c, 0, 1)), compiled step (``jit=True``; the virtual machine without a C
compiler); medians over `--repeat` rounds, in microseconds per run; the results are
compared bit for bit.

    python benchmarks/lockstep.py                       # 250 runs of 1000 steps, 9 rounds
    python benchmarks/lockstep.py --runs 1000 --steps 100
"""

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.simulation.lockstep import groups, run_lockstep, simulate_lockstep, simulate_runs  # noqa: E402
from dmoc.simulation.preparation import prepare_runs  # noqa: E402
from dmoc.simulation.time_stepping import conclude  # noqa: E402
from knife_runs import knife_edge_runs  # noqa: E402

FIELDS = ("t", "q", "p", "lam", "u", "mu", "s")


def rounds(disc, runs, repeat):
    """{label: [seconds per run of each round]}."""
    times = {}

    def clock(label, work):
        tic = time.perf_counter()
        value = work()
        times.setdefault(label, []).append((time.perf_counter() - tic) / len(runs))
        return value

    for _ in range(repeat):
        serial = clock("serial loop", lambda: [dmoc.simulate(disc, **run, throw=False) for run in runs])
        together = clock("lockstep", lambda: simulate_runs(disc, runs))
        assert all(np.array_equal(getattr(a.trajectory, f), getattr(b.trajectory, f))
                   for a, b in zip(serial, together) for f in FIELDS)
        prepared = clock("  prepare", lambda: prepare_runs(disc, [dict(run, throw=False)
                                                                  for run in runs]))
        alone = clock("  steps, one run at a time", lambda: [
            r.stepper.run(r.start, r.controls, disc.h) for r in prepared])
        clock("  steps in lockstep", lambda: [run_lockstep(
            prepared[0].stepper, np.array([prepared[i].start for i in members]),
            np.array([prepared[i].controls for i in members]), disc.h)
            for members in groups(prepared)])
        clock("  lockstep + conclude_group", lambda: simulate_lockstep(prepared))
        clock("  ... last knot only", lambda: simulate_lockstep(prepared, final=True))
        clock("  conclude", lambda: [conclude(r, a) for r, a in zip(prepared, alone)])
        clock("  conclude, last knot only", lambda: [conclude(r, a, final=True)
                                                      for r, a in zip(prepared, alone)])
    return times


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=250)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=9)
    args = parser.parse_args(argv)
    disc, runs = knife_edge_runs(args.runs, args.steps)
    jit = runs[0]["jit"]
    rounds(disc, runs[:20], 1)                                  # build, compile, warm up
    print(f"{args.runs} knife-edge runs of {args.steps} steps, jit={jit}, {args.repeat} rounds, "
          "load average %.2f %.2f %.2f" % os.getloadavg())
    times = rounds(disc, runs, args.repeat)
    serial = np.median(times["serial loop"])
    print(f"{'':28s} {'us/run':>8s} {'serial/this':>12s}")
    for label, values in times.items():
        print(f"{label:28s} {np.median(values) * 1e6:8.1f} {serial / np.median(values):12.2f}")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
