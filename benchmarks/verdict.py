"""Benchmark: what the verdict costs, `dmoc.optimize` (``check=True``, the default) against
IPOPT's solve alone (``check=False``) on the same problem, in the same process.

For knife-edge parking and rolling-disk steering (dmoc.problems, variant "+") with each rule
at each N: "first" is the process's first judged solve of that structure and rule (the
replay's Newton step is built then, once per discretization structure); "again" a judged
re-solve of the same problem; "raw" the same re-solve with ``check=False``. Reported: wall
milliseconds of the optimize call (best of `--repeat` fresh processes for "first", best of
`--repeat` calls for the others) and the ratios judged / raw.

    python benchmarks/verdict.py [--repeat 3] [--steps 100 1000] [--rules midpoint lobatto3 lobatto4]
"""

import argparse
import os
import platform
import subprocess
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import dmoc  # noqa: E402
import dmoc.problems  # noqa: E402

CASES = {"knife edge": dmoc.problems.knife_edge_parking,
         "rolling disk": dmoc.problems.rolling_disk_steering}
RULES = ("midpoint", "lobatto3", "lobatto4")
STEPS = (100, 1000)


def seconds(call):
    tic = time.perf_counter()
    call()
    return time.perf_counter() - tic


def one_process(name, rule, N, repeat):
    """(this process) 'first again raw' seconds for one case."""
    problem = CASES[name](N, rule=rule)
    dmoc.optimize(problem, check=False)                 # the NLP solver is built
    first = seconds(lambda: dmoc.optimize(problem))     # the replay's step is built
    again = min(seconds(lambda: dmoc.optimize(problem)) for _ in range(repeat))
    raw = min(seconds(lambda: dmoc.optimize(problem, check=False)) for _ in range(repeat))
    return f"{first} {again} {raw}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--steps", type=int, nargs="+", default=STEPS, help="N (default 100 1000)")
    parser.add_argument("--rules", nargs="+", default=RULES, choices=RULES)
    parser.add_argument("--child", nargs=3)
    args = parser.parse_args(argv)
    if args.child:
        name, rule, N = args.child
        print(one_process(name, rule, int(N), args.repeat))
        return
    print(f"# {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"dmoc at {os.path.dirname(dmoc.__file__)}; load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    print(f"{'problem':13s} {'rule':9s} {'N':>5s} {'first ms':>9s} {'again ms':>9s} {'raw ms':>9s} "
          f"{'first/raw':>9s} {'again/raw':>9s}")
    for name in CASES:
        for rule in args.rules:
            for N in args.steps:
                firsts, again, raw = [], None, None
                for _ in range(args.repeat):
                    out = subprocess.run([sys.executable, __file__, "--repeat", str(args.repeat),
                                          "--child", name, rule, str(N)],
                                         capture_output=True, text=True, check=True)
                    f, a, r = map(float, out.stdout.split())
                    firsts.append(f)
                    again, raw = min(again or a, a), min(raw or r, r)
                first = min(firsts)
                print(f"{name:13s} {rule:9s} {N:5d} {first * 1e3:9.2f} {again * 1e3:9.2f} {raw * 1e3:9.2f} "
                      f"{first / raw:9.2f} {again / raw:9.2f}", flush=True)
    print(f"# load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
