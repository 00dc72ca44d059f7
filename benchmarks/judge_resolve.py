"""Benchmark: the verdict alone (`dmoc.drivers.verdict.judge`) on the re-solves of
`peers_resolve.py`, per dmoc checkout (issue 25; docs/performance.md, "The verdict of a
re-solve").

For rolling-disk steering and knife-edge parking at the N of equal accuracy found by
`peers_resolve.py` (lobatto3 and lobatto4), a child process per checkout (PYTHONPATH set
to it) solves the goals of `peers_resolve.goals` in a cycle with ``check=False``, each
from the previous optimum, then times `judge` on every optimum, `--repeat` passes after a
first one that builds what the verdict keeps: the median milliseconds per verdict. The
children of the checkouts run interleaved, `--rounds` times; per case the round of least
time is kept, and the ratio is to the first checkout's.

    python benchmarks/judge_resolve.py --checkouts /work/main . [--repeat 20] [--rounds 3]
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

from peers_resolve import dmoc_problem, goals, moved

CASES = (("rolling disk", "lobatto3", 31), ("rolling disk", "lobatto4", 11),
         ("knife edge", "lobatto3", 28), ("knife edge", "lobatto4", 14))


def judge_times(name, rule, N, repeat):
    """(this process) Median ms of `judge` over the optima of the goals' cycle."""
    import dmoc
    from dmoc.drivers.verdict import judge
    targets = goals(name, 5)
    problem = dmoc_problem(name, N, rule, targets[0])
    previous = dmoc.optimize(problem, check=False, options={"print_level": 0})
    optima = []
    for goal in list(targets[1:]) + [targets[0]]:
        moved_problem = moved(problem, name, goal)
        previous = dmoc.optimize(moved_problem, guess=previous, check=False,
                                 options={"print_level": 0})
        optima.append((moved_problem, previous))
    seconds = []
    for _ in range(repeat + 1):
        for moved_problem, result in optima:
            tic = time.perf_counter()
            judge(moved_problem, result)
            seconds.append(time.perf_counter() - tic)
    return float(np.median(seconds[len(optima):])) * 1e3


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkouts", nargs="+", default=[os.getcwd()])
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--child", nargs=3)
    args = parser.parse_args(argv)
    if args.child:
        name, rule, N = args.child
        print(json.dumps(judge_times(name, rule, int(N), args.repeat)))
        return
    print(f"# Python {platform.python_version()}, load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()}")
    best = {}
    for _ in range(args.rounds):
        for case in CASES:
            for checkout in args.checkouts:
                env = {**os.environ, "PYTHONPATH": os.path.abspath(checkout)}
                out = subprocess.run([sys.executable, __file__, "--repeat", str(args.repeat),
                                      "--child", case[0], case[1], str(case[2])], env=env,
                                     check=True, capture_output=True, text=True).stdout
                ms = json.loads(out.strip().splitlines()[-1])
                best[case, checkout] = min(best.get((case, checkout), np.inf), ms)
    print(f"{'problem':13s} {'rule':9s} {'N':>3s} {'checkout':>20s} {'judge ms':>9s} {'ratio':>6s}")
    for case in CASES:
        base = best[case, args.checkouts[0]]
        for checkout in args.checkouts:
            ms = best[case, checkout]
            print(f"{case[0]:13s} {case[1]:9s} {case[2]:3d} "
                  f"{os.path.basename(os.path.abspath(checkout)):>20s} {ms:9.3f} {ms / base:6.2f}")
    print(f"# load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
