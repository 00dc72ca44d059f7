"""Benchmark: stage rules (lobatto3, lobatto4) from the default guess on hard problems, the
solve before issue 40 (IPOPT from the default guess, judged: `judged_solve`) against
`dmoc.optimize`'s default path (the midpoint rule's optimum on the same grid first,
`dmoc.drivers.high_order`), in one process.

Problems (tests/optimize/hard_problems.py and examples/): the truck backing a trailer into
a bay (free final time, bounds, a steering-rate row, speed, jack-knife, discs, road edge),
the lane change past a parked car (examples/lane_change_problem.py) and the rolling disk
with |u| <= 1 and a free final time. Per rule and N: the verdict's status, iterations
(the start's + the stage rule's), wall seconds, final time, cost, and the replay's
departure, before and now; and per problem the midpoint rule's cost at N and 2N and their
Richardson limit J* = J_2N + (J_2N - J_N) / 3.

    python benchmarks/high_order.py [--problems truck lane disk] [--steps 30 60]
"""

import argparse
import os
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [ROOT, os.path.join(ROOT, "examples")]

import dmoc  # noqa: E402
from dmoc.drivers.verdict import judged_solve  # noqa: E402


def problems():
    """{name: make(steps, rule)}."""
    from tests.optimize.hard_problems import bounded_disk, truck_bay
    from lane_change_problem import lane_change
    return {"truck": truck_bay, "lane": lambda steps, rule: lane_change(steps).with_rule(rule),
            "disk": bounded_disk}


def timed(call):
    tic = time.perf_counter()
    result = call()
    return result, time.perf_counter() - tic


def cells(result, seconds):
    start = result.stats.get("start") or {}
    iterations = f"{start['iterations']}+" if start else ""
    replay = result.verdict.replay_q if result.verdict is not None else float("nan")
    return (f"{str(result.status):>16}{iterations + str(result.stats['iterations']):>9}{seconds:>7.1f}"
            f"{result.trajectory.t[-1]:>8.3f}{result.cost:>14.9f}{replay:>9.1e}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problems", nargs="+", default=["truck", "lane", "disk"],
                        choices=["truck", "lane", "disk"])
    parser.add_argument("--steps", nargs="+", type=int, default=[30, 60])
    args = parser.parse_args(argv)
    makes = problems()
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    print(f"{'problem':<7}{'rule':<9}{'N':>4} | {'before: status':>16}{'it':>9}{'s':>7}{'T':>8}{'J':>14}"
          f"{'replay':>9} | {'now: status':>16}{'it':>9}{'s':>7}{'T':>8}{'J':>14}{'replay':>9}")
    for name in args.problems:
        make = makes[name]
        for steps in args.steps:
            for rule in ("lobatto3", "lobatto4"):
                before = timed(lambda: judged_solve(make(steps, rule), throw=False))
                now = timed(lambda: dmoc.optimize(make(steps, rule), throw=False))
                print(f"{name:<7}{rule:<9}{steps:>4} | {cells(*before)} | {cells(*now)}", flush=True)
        N = max(args.steps)
        mid = [dmoc.optimize(make(steps, "midpoint"), throw=False) for steps in (N, 2 * N)]
        J = [result.cost for result in mid]
        limit = f"{J[1] + (J[1] - J[0]) / 3:.9f}" if all(r.success for r in mid) else "-"
        print(f"{name:<7}midpoint J_N {J[0]:.9f} ({mid[0].status}), J_2N {J[1]:.9f} ({mid[1].status}) "
              f"(N = {N}): Richardson limit {limit}", flush=True)
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
