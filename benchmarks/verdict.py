"""Benchmark: what the verdict costs, `dmoc.optimize` (``check=True``, the default) against
IPOPT's solve alone (``check=False``) on the same problem, in the same process.

For knife-edge parking and rolling-disk steering (dmoc.problems, variant "+") with each rule
at each N: "first" is the process's first judged solve of that structure and rule (the
replay's Newton step is built then, once per discretization structure); "again" a judged
re-solve of the same problem; "raw" the same re-solve with ``check=False``. Reported: wall
milliseconds of the optimize call (best of `--repeat` fresh processes for "first", best of
`--repeat` calls for the others) and the ratios judged / raw.

    python benchmarks/verdict.py [--repeat 3] [--steps 100 1000] [--rules midpoint lobatto3 lobatto4]

With ``--hard``, instead: stage rules (lobatto3, lobatto4) from the default guess on hard
problems, the solve before issue 40 (IPOPT from the default guess, judged: `judged_solve`)
against `dmoc.optimize`'s default path (the midpoint rule's optimum on the same grid first,
`dmoc.drivers.high_order`): the truck backing a trailer into a bay and the rolling disk
with |u| <= 1 and a free final time (tests/optimize/hard_problems.py), the lane change
past a parked car (examples/lane_change_problem.py). Per problem, rule and N: the verdict's
status, iterations (the start's + the stage rule's), wall seconds, final time, cost and
the replay's departure, before and now; per problem the midpoint rule's cost at N and 2N
(N the largest of `--steps`) and their Richardson limit J_2N + (J_2N - J_N) / 3.

    python benchmarks/verdict.py --hard truck lane disk --steps 30 60

With ``--hard truck --rates``, instead: the truck with its steering-rate limit |delta'| <=
0.4 written as a path row (the baseline) and as a velocity bound, lobatto3 and lobatto4 at
each N of `--steps` from the default guess: status, iterations (the midpoint start's + the
stage rule's), wall seconds, final time, cost, replay, the largest rate |delta'| over 0.4 at
the knots (the verdict's knot velocity) and at the stage nodes, recomputed from the
trajectory by numpy polynomials through the Lobatto nodes
(tests/optimize/test_knot_rates.py, not dmoc's interpolant), and the seconds of the bound
over those of the row.

    python benchmarks/verdict.py --hard truck --rates --steps 60 120

With ``--study COUNT``, instead: the verdict's quality on COUNT seeded random problems
(knife edge, rolling disk, car, a Chaplygin sleigh built in the study; random SI data,
goals, horizons, N, rules, free final times, control bounds, keep-out discs), each
optimum's truth from an independent transcription (RK4 multiple shooting of the continuous
equations, IPOPT through CasADi) and a DOP853 replay of its controls
(tests/results/verdict_study.py): per problem the status (with the estimate, as
``estimate=True`` gives it), dmoc's own error estimate, the true errors (cost, final
time, replay, path along the replay), the truth's uncertainty and the class (true/false
success, true/false refusal; the default verdict's where it differs); then the counts of
both.

    python benchmarks/verdict.py --study 40 [--seed 40]
"""

import argparse
import os
import platform
import subprocess
import sys
import time

import numpy as np

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

import dmoc  # noqa: E402
import dmoc.problems  # noqa: E402
from dmoc.drivers.verdict import judged_solve  # noqa: E402

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


def hard_problems():
    """{name: make(steps, rule)} of the `--hard` problems."""
    sys.path[:0] = [ROOT, os.path.join(ROOT, "examples")]
    from tests.optimize.hard_problems import bounded_disk, truck_bay
    from lane_change_problem import lane_change
    return {"truck": truck_bay, "lane": lambda steps, rule: lane_change(steps).with_rule(rule),
            "disk": bounded_disk}


def _timed(call):
    tic = time.perf_counter()
    result = call()
    return result, time.perf_counter() - tic


def _cells(result, seconds):
    start = result.stats.get("start") or {}
    iterations = f"{start['iterations']}+" if start else ""
    replay = result.verdict.replay_q if result.verdict is not None else float("nan")
    return (f"{str(result.status):>16}{iterations + str(result.stats['iterations']):>9}{seconds:>7.1f}"
            f"{result.trajectory.t[-1]:>8.3f}{result.cost:>14.9f}{replay:>9.1e}")


def hard(names, steps):
    """The `--hard` table of the problems `names` at each N of `steps`."""
    makes = hard_problems()
    print(f"{'problem':<7}{'rule':<9}{'N':>4} | {'before: status':>16}{'it':>9}{'s':>7}{'T':>8}{'J':>14}"
          f"{'replay':>9} | {'now: status':>16}{'it':>9}{'s':>7}{'T':>8}{'J':>14}{'replay':>9}")
    for name in names:
        make = makes[name]
        for N in steps:
            for rule in ("lobatto3", "lobatto4"):
                before = _timed(lambda: judged_solve(make(N, rule), throw=False))
                now = _timed(lambda: dmoc.optimize(make(N, rule), throw=False))
                print(f"{name:<7}{rule:<9}{N:>4} | {_cells(*before)} | {_cells(*now)}", flush=True)
        N = max(steps)
        mid = [dmoc.optimize(make(n, "midpoint"), throw=False) for n in (N, 2 * N)]
        J = [result.cost for result in mid]
        limit = f"{J[1] + (J[1] - J[0]) / 3:.9f}" if all(r.success for r in mid) else "-"
        print(f"{name:<7}midpoint J_N {J[0]:.9f} ({mid[0].status}), J_2N {J[1]:.9f} ({mid[1].status}) "
              f"(N = {N}): Richardson limit {limit}", flush=True)


def rates(steps):
    """The `--rates` table: the truck's steering rate as a path row and as a bound."""
    sys.path[:0] = [ROOT]
    from tests.optimize.hard_problems import STEERING_RATE, truck_bay
    from tests.optimize.test_knot_rates import knot_and_stage_velocities
    print(f"{'rule':<9}{'N':>4}{'written':>8} | {'status':>16}{'it':>9}{'s':>7}{'T':>8}{'J':>14}{'replay':>9}"
          f"{'knots-0.4':>11}{'nodes-0.4':>11}{'bound/row s':>12}")
    for N in steps:
        for rule in ("lobatto3", "lobatto4"):
            row_seconds = None
            for written in ("path", "bound"):
                problem = truck_bay(N, rule, written)
                result, seconds = _timed(lambda: dmoc.optimize(problem, throw=False))
                over = [np.abs(v[:, 3]).max() - STEERING_RATE
                        for v in knot_and_stage_velocities(result.trajectory, rule)]
                row_seconds = row_seconds or seconds
                print(f"{rule:<9}{N:>4}{written:>8} | {_cells(result, seconds)}"
                      f"{over[0]:>+11.1e}{over[1]:>+11.1e}{seconds / row_seconds:>12.2f}", flush=True)


def study(count, seed):
    """The `--study` table: the verdict's class on `count` random problems of `seed`."""
    sys.path[:0] = [ROOT]
    from tests.results.verdict_study import counts, random_problems, study as judged_case
    print(f"{'problem':<52}{'status':>17}{'estimate':>9}{'dJ':>9}{'dT':>9}{'replay':>9}{'path':>9}"
          f"{'truth':>9}  class")
    rows = []
    for case in random_problems(count, seed):
        row = judged_case(case)
        rows.append(row)
        print(f"{row.label:<52}{row.status:>17}" + "".join(
            f"{x:>9.1e}" for x in (row.estimate, row.cost_error, row.time_error, row.departure, row.path,
                                   row.truth_uncertainty)) + f"  {row.kind}"
              + ("" if row.default_kind == row.kind else f" (default verdict: {row.default_kind})"), flush=True)
    for field, name in (("kind", "with the estimate (estimate=True)"), ("default_kind", "default verdict")):
        print(f"counts, {name}: " + ", ".join(f"{kind} {number}" for kind, number in counts(rows, field).items()))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--steps", type=int, nargs="+", default=STEPS, help="N (default 100 1000)")
    parser.add_argument("--rules", nargs="+", default=RULES, choices=RULES)
    parser.add_argument("--child", nargs=3)
    parser.add_argument("--hard", nargs="+", choices=["truck", "lane", "disk"], metavar="NAME",
                        help="stage rules from the default guess on truck, lane, disk, before and now")
    parser.add_argument("--rates", action="store_true",
                        help="with --hard truck: the steering rate as a path row and as a velocity bound")
    parser.add_argument("--study", type=int, metavar="COUNT",
                        help="the verdict's quality on COUNT random problems against independent truths")
    parser.add_argument("--seed", type=int, default=40, help="with --study: the problems' seed")
    args = parser.parse_args(argv)
    if args.study:
        print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
        study(args.study, args.seed)
        print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")
        return
    if args.hard:
        print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
        rates(args.steps) if args.rates else hard(args.hard, args.steps)
        print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")
        return
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
