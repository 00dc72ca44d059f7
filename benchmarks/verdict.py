"""Benchmark: what the verdict costs against the solve it judges, on a first solve and on a
re-solve with new boundary data, both by `dmoc.optimize` as a user calls it (judged, no
extra flags).

For knife-edge parking and rolling-disk steering (dmoc.problems) with lobatto3 and
lobatto4, each at its least N within 1e-6 of the continuous optimum (benchmarks/peers.py),
and knife-edge parking past a keep-out disc (a path row, read between the knots too):
"first" is a solve after `dmoc.clear_caches` (everything built as in a new process: the
solver, the midpoint rule's start, the replay's step); "re-solve" the problem moved to a
goal near the last (``problem.with_boundary(q_goal=...)``) solved from the last optimum
(``guess=``), cycling through 5 goals. For each: the verdict's CPU milliseconds (of the
`judge` call; ``stats["verdict_time"]`` holds its wall time), the solve's (the optimize
call less its verdict; the problem's construction not counted) and the ratio verdict /
solve, medians over `--rounds` first solves and `--rounds` cycles
of re-solves in each of `--repeat` processes per checkout, the checkouts interleaved
(`--checkouts`, default this one), with the least and largest ratio of a process.

    python benchmarks/verdict.py [--repeat 3] [--rounds 5] [--checkouts /work/main .]
    python benchmarks/verdict.py --smallest     # the knife edge, lobatto3, one process

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
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

import dmoc  # noqa: E402
import dmoc.drivers.verdict  # noqa: E402
import dmoc.problems  # noqa: E402
from dmoc.drivers.verdict import judged_solve  # noqa: E402
from resolve import add_checkouts, imported_dmoc  # noqa: E402

def parking_past_a_disc(steps, rule):
    """Knife-edge parking with a keep-out disc of radius 0.2 at (0.05, 0.5), which its
    path touches: the verdict reads the row at the knots and between them."""
    disc = dmoc.problems.knife_edge_parking(steps, rule=rule).disc
    return dmoc.OptimalControlProblem(disc, steps, q_start=[0.0, 0.0, 0.0], q_goal=[0.0, 1.0, 0.0],
                                      path_constraints=lambda q, v, u: 0.04 - (q[0] - 0.05) ** 2
                                      - (q[1] - 0.5) ** 2)


CASES = {"knife edge": dmoc.problems.knife_edge_parking,
         "rolling disk": dmoc.problems.rolling_disk_steering,
         "disc parking": parking_past_a_disc}
# the least N within 1e-6 of J* (benchmarks/peers.py, LEAST_N); the knife edge's past the disc
LEAST_N = {"knife edge": {"lobatto3": 28, "lobatto4": 14},
           "rolling disk": {"lobatto3": 31, "lobatto4": 11},
           "disc parking": {"lobatto3": 28, "lobatto4": 14}}
RULES = ("lobatto3", "lobatto4")
# goals near the problems' own, (x, y, heading), as in benchmarks/peers.py
OFFSETS = np.array([[0.05, 0.0, 0.0], [0.0, 0.05, 0.05], [-0.05, 0.05, 0.0],
                    [0.05, -0.05, -0.05], [0.0, 0.0, 0.0]])


def goal(name, offset):
    """The q_goal of `name` moved by `offset` = (dx, dy, dheading); the disk's rolling
    angle stays free."""
    if name != "rolling disk":
        return list(np.array([0.0, 1.0, 0.0]) + offset)
    x, y, heading = np.array([1.0, 1.0, np.pi / 2]) + offset
    return [x, y, None, heading]


def judge_seconds():
    """seconds() -> the CPU seconds of the last call of `dmoc.drivers.verdict.judge`,
    which this wraps (what ``stats["verdict_time"]`` holds as wall seconds), the result's
    trajectory built before (a deferred field: the solve's product, which the verdict
    reads first)."""
    spent, judge = [0.0], dmoc.drivers.verdict.judge

    def timed(problem, result):
        result.trajectory       # built on first reading (the solve's), as judged_solve does
        tic = time.process_time()
        verdict = judge(problem, result)
        spent[0] = time.process_time() - tic
        return verdict
    dmoc.drivers.verdict.judge = timed
    return lambda: spent[0]


def one_process(name, rule, rounds, goals):
    """(this process) JSON {"first": [[verdict s, solve s], ...], "re-solve": [...]} of
    `rounds` first solves and `rounds` cycles of re-solves through the last `goals` goals
    of OFFSETS, in CPU seconds (`time.process_time`)."""
    seconds, N = judge_seconds(), LEAST_N[name][rule]
    rows = {"first": [], "re-solve": []}

    def timed(run, problem, **keywords):
        tic = time.process_time()
        result = dmoc.optimize(problem, **keywords)
        verdict = seconds()
        rows[run].append([verdict, time.process_time() - tic - verdict])
        if not (result.success and result.verdict.passed):
            raise RuntimeError(f"{name} {rule}: {result.message}")
        return result
    for _ in range(rounds):
        dmoc.clear_caches()
        problem = CASES[name](N, rule=rule)
        previous = timed("first", problem)
    for _ in range(rounds):
        for offset in OFFSETS[-goals:]:
            previous = timed("re-solve", problem.with_boundary(q_goal=goal(name, offset)),
                             guess=previous)
    return json.dumps(rows)


def cost_table(args):
    """The table of verdict / solve, per checkout, problem and rule."""
    for checkout in args.checkouts:
        print(f"# {checkout}: {imported_dmoc(checkout)}")
    print(f"{'checkout':<14}{'problem':<13}{'rule':<9}{'N':>3} | {'first: verdict cpu ms':>21}"
          f"{'solve ms':>9}{'ratio':>7}{'(range)':>14} | {'re-solve: verdict cpu ms':>24}{'solve ms':>9}"
          f"{'ratio':>7}{'(range)':>14}")
    cases = [("knife edge", "lobatto3")] if args.smallest else \
        [(name, rule) for name in CASES for rule in RULES]
    for name, rule in cases:
        rows = {c: [] for c in args.checkouts}
        for _ in range(args.repeat):
            for checkout in args.checkouts:         # interleaved: all see the same load
                out = subprocess.run(
                    [sys.executable, __file__, "--child", name, rule, str(args.rounds),
                     str(args.goals)], env={**os.environ, "PYTHONPATH": checkout},
                    cwd=tempfile.gettempdir(), capture_output=True, text=True, check=True)
                rows[checkout].append(json.loads(out.stdout))
        for checkout in args.checkouts:
            cells = []
            for run in ("first", "re-solve"):
                every = np.array([r for process in rows[checkout] for r in process[run]])
                verdict, solve = np.median(every, axis=0)
                ratios = [np.median(np.array(p[run])[:, 0]) / np.median(np.array(p[run])[:, 1])
                          for p in rows[checkout]]
                cells.append(f"{verdict * 1e3:>{21 if run == 'first' else 24}.2f}{solve * 1e3:>9.2f}"
                             f"{verdict / solve:>7.3f}{f' ({min(ratios):.3f}-{max(ratios):.3f})':>14}")
            print(f"{os.path.basename(os.path.normpath(checkout)):<14}{name:<13}{rule:<9}"
                  f"{LEAST_N[name][rule]:>3} | {cells[0]} | {cells[1]}", flush=True)


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
    parser.add_argument("--repeat", type=int, default=3, help="processes per checkout (default 3)")
    parser.add_argument("--rounds", type=int, default=5,
                        help="first solves, and cycles of re-solves, per process (default 5)")
    parser.add_argument("--goals", type=int, default=len(OFFSETS), choices=range(1, len(OFFSETS) + 1),
                        help=f"goals per cycle of re-solves (default {len(OFFSETS)})")
    parser.add_argument("--smallest", action="store_true",
                        help="the knife edge with lobatto3, one process, one round of 2 goals")
    parser.add_argument("--steps", type=int, nargs="+", default=[30, 60], help="N, with --hard (default 30 60)")
    parser.add_argument("--child", nargs=4)
    parser.add_argument("--hard", nargs="+", choices=["truck", "lane", "disk"], metavar="NAME",
                        help="stage rules from the default guess on truck, lane, disk, before and now")
    parser.add_argument("--rates", action="store_true",
                        help="with --hard truck: the steering rate as a path row and as a velocity bound")
    add_checkouts(parser)
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
        name, rule, rounds, goals = args.child
        print(one_process(name, rule, int(rounds), int(goals)))
        return
    if args.smallest:
        args.repeat, args.rounds, args.goals = 1, 1, 2
    print(f"# {platform.processor() or platform.machine()}, Python {platform.python_version()}; "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    cost_table(args)
    print(f"# load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
