"""Benchmark: the cost of one `dmoc.simulate` call, its fixed part and its part per step,
for one or several checkouts in one run (docs/performance.md, "Batches that scale: a
simulate call's fixed cost").

Knife edge, h = 0.01, v0 = (1, 0, 1), compiled step (``jit=True``; the virtual machine
where there is no C compiler), the step built before timing. For each checkout a child
process times `--calls` calls of each number of steps in `--steps`, interleaved call by
call so that the sizes see the same load; the children of the checkouts alternate over
`--repeat` rounds. Reported: the median over the rounds of the median wall time per call,
in ms, and the ratio of each checkout to the first.

    python benchmarks/simulate_call.py
    python benchmarks/simulate_call.py --checkouts /work/main /path/to/branch     # before/after
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from checkouts import add_checkouts, imported_dmoc  # noqa: E402


def calls(steps, count):
    """{steps: median seconds per call} of `count` calls of each size, in this process."""
    import dmoc
    from dmoc._util import compiled
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.01)
    jit = compiled.compiler() is not None
    for n in steps:
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=n, jit=jit)
    times = {n: [] for n in steps}
    for _ in range(count):
        for n in steps:
            tic = time.perf_counter()
            dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=n, jit=jit)
            times[n].append(time.perf_counter() - tic)
    return {n: float(np.median(t)) for n, t in times.items()}


def child(checkout, args):
    out = subprocess.run([sys.executable, __file__, "--child", "--calls", str(args.calls),
                          "--steps", *map(str, args.steps)],
                         env={**os.environ, "PYTHONPATH": checkout}, cwd=tempfile.gettempdir(),
                         capture_output=True, text=True, check=True).stdout
    return {int(k): v for k, v in json.loads(out).items()}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=3)
    add_checkouts(parser)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(calls(args.steps, args.calls)))
        return
    print(f"# {platform.platform()}, {os.cpu_count()} cores; load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    for checkout in args.checkouts:
        print(f"# {checkout}: dmoc from {imported_dmoc(checkout)}")
    rounds = {c: [] for c in args.checkouts}
    for _ in range(args.repeat):
        for checkout in args.checkouts:         # interleaved: all see the same load
            rounds[checkout].append(child(checkout, args))
    print(f"\n{'steps':>6s} " + " ".join(f"{'ms/call #' + str(i):>12s}" for i in range(len(args.checkouts)))
          + " " + " ".join(f"{'ratio #' + str(i):>9s}" for i in range(1, len(args.checkouts))))
    for n in args.steps:
        ms = [1e3 * float(np.median([r[n] for r in rounds[c]])) for c in args.checkouts]
        print(f"{n:6d} " + " ".join(f"{m:12.3f}" for m in ms) + " "
              + " ".join(f"{ms[0] / m:9.2f}" for m in ms[1:]))
    print(f"# load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
