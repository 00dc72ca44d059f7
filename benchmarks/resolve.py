"""Benchmark: re-solving a DMOC problem with new boundary data, cold and warm-started,
against its first solve.

For knife-edge parking and rolling-disk steering (dmoc.problems, midpoint rule, variant
"+") at each N: "first" builds the problem for goal A and solves it (the process's first
solve of that structure: the NLP solver is created); "re-solve" builds the problem for a
neighbouring goal B anew and solves it from the default guess; "warm" solves B from A's
optimum (``guess=result``: x and IPOPT's multipliers; on a checkout without dual warm
starts, its trajectory); "primal" solves B from A's trajectory only. Reported: wall time of
construction + optimize (best of `--repeat`, each repeat in a fresh process so that
"first" really is first), IPOPT iterations, and the ratios to "first" (time) and to
"re-solve" (iterations).

    python benchmarks/resolve.py
    python benchmarks/resolve.py --smallest      # the knife edge at N = 20, one process
    python benchmarks/resolve.py --checkouts /work/main /path/to/branch   # interleaved
    python benchmarks/resolve.py --sensitivities  # dmoc.sensitivities against a warm re-solve

With ``--sensitivities``, a second table, in this process: the derivatives of A's optimum in q_goal
(`dmoc.sensitivities`, first call with its build in wall seconds, then the least CPU seconds
of `--repeat`) against the warm re-solve of B from A's optimum (``problem.with_boundary(q_goal=B)``
and optimize, least CPU seconds of `--repeat`); both run on one thread, so CPU time is their cost
whatever the other processes on the machine do (wall times of calls of a few ms moved by 2x at a
load average of 7 on 2 cores). The ratio is sensitivities / warm re-solve (the goal: at most
0.2). The table adds "bounded knife", the knife edge with control bounds active on about a third
of the steps.
"""

import argparse
import os
import pathlib
import platform
import subprocess
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
import dmoc.problems  # noqa: E402

CASES = {
    "knife edge": lambda N, goal: dmoc.problems.knife_edge_parking(N, goal=goal),
    "rolling disk": lambda N, goal: dmoc.OptimalControlProblem(
        dmoc.discretize(dmoc.systems.rolling_disk(mass=1.0, radius=1.0), 4.0 / N), N,
        q_start=[0.0] * 4, q_goal=goal),
}
# the knife edge with its controls bounded, active on 42 of 120 entries at N = 60 (the
# ``--sensitivities`` table alone: an active set that changes with the goal)
BOUNDED = {"bounded knife": lambda N, goal: dmoc.OptimalControlProblem(
    dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=1.0), 4.0 / N), N,
    q_start=[0.0] * 3, q_goal=goal, control_bounds=([-1.2, -1.5], [1.2, 1.5]))}
GOALS = {"knife edge": ((0.0, 1.0, 0.0), (0.1, 1.1, 0.1)),
         "rolling disk": ((1.0, 1.0, None, np.pi / 2), (1.1, 0.9, None, np.pi / 2 + 0.1)),
         "bounded knife": ((0.0, 1.0, 0.0), (0.1, 1.1, 0.1))}
STEPS = (100, 400, 1000)
RUNS = ("first", "re-solve", "warm", "primal")


def imported_dmoc(checkout):
    """The path of the dmoc package a child process imports with PYTHONPATH = `checkout`,
    run outside the checkouts (`python -m` would put the working folder first)."""
    return subprocess.run([sys.executable, "-c", "import dmoc; print(dmoc.__file__)"],
                          env={**os.environ, "PYTHONPATH": checkout}, cwd=tempfile.gettempdir(),
                          capture_output=True, text=True, check=True).stdout.strip()


def add_checkouts(parser):
    """`parser`'s option ``--checkouts DIR ...``: the dmoc checkouts a benchmark compares,
    each on PYTHONPATH in turn in a child process (default: the checkout holding this
    folder); `mpc.py` takes it too."""
    parser.add_argument("--checkouts", nargs="+", default=[str(pathlib.Path(__file__).resolve().parents[1])],
                        help="dmoc checkouts to compare, each on PYTHONPATH in turn (default: this one)")


def timed(make, guess=None):
    """(seconds for construction + optimize, result)."""
    tic = time.perf_counter()
    result = dmoc.optimize(make(), guess=guess)
    return time.perf_counter() - tic, result


def one_process(name, N):
    """(this process) the four runs of case `name` at N: 'seconds iterations' each."""
    a, b = GOALS[name]
    make = CASES[name]
    first = timed(lambda: make(N, a))
    resolve = timed(lambda: make(N, b))
    dual = first[1] if hasattr(first[1], "lam_g") else first[1].trajectory
    warm = timed(lambda: make(N, b), dual)
    primal = timed(lambda: make(N, b), first[1].trajectory)
    for seconds, result in (first, resolve, warm, primal):
        if not result.success:
            raise RuntimeError(result.message)
    assert abs(warm[1].cost - resolve[1].cost) < 1e-8
    print(*(f"{s:.5f} {r.stats['iterations']}" for s, r in (first, resolve, warm, primal)))


def best_of(repeat, run, clock=time.perf_counter):
    """(least seconds of `clock`, wall by default, of `repeat` calls of `run`, its last
    value)."""
    times = []
    for _ in range(repeat):
        tic = clock()
        value = run()
        times.append(clock() - tic)
    return min(times), value


def sensitivity_rows(cases, steps, repeat):
    """(this process) the ``--sensitivities`` table: per case and N, the warm re-solve of
    goal B from A's optimum and `dmoc.sensitivities` of A's optimum in q_goal."""
    head = (f"{'case':<14}{'N':>6}{'warm cpu s':>12}{'it':>4}{'sens first s':>14}{'sens cpu s':>12}"
            f"{'sens/warm':>11}")
    print(head + "\n" + "-" * len(head))
    for name in cases:
        for N in steps:
            a, b = GOALS[name]
            problem = {**CASES, **BOUNDED}[name](N, a)
            first = dmoc.optimize(problem)
            warm, moved = best_of(repeat, lambda: dmoc.optimize(problem.with_boundary(q_goal=b), guess=first),
                                  time.process_time)
            build = best_of(1, lambda: dmoc.sensitivities(problem, first, wrt="q_goal"))[0]
            sens = best_of(repeat, lambda: dmoc.sensitivities(problem, first, wrt="q_goal"), time.process_time)[0]
            print(f"{name:<14}{N:>6}{warm:>12.4f}{moved.stats['iterations']:>4}{build:>14.4f}"
                  f"{sens:>12.4f}{sens / warm:>11.2f}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--one":
        one_process(argv[1], int(argv[2]))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="fresh processes per case (default 3)")
    parser.add_argument("--steps", type=int, nargs="+", default=STEPS, help="N (default 100 400 1000)")
    parser.add_argument("--smallest", action="store_true", help="the knife edge at N = 20, one process")
    parser.add_argument("--sensitivities", action="store_true",
                        help="add the table of dmoc.sensitivities against a warm re-solve")
    add_checkouts(parser)
    args = parser.parse_args(argv)
    cases, steps = (("knife edge",), (20,)) if args.smallest else (CASES, args.steps)
    args.repeat = 1 if args.smallest else args.repeat
    print(f"python {platform.python_version()}, casadi {ca.__version__}; load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()}; checkouts {', '.join(args.checkouts)}")
    head = (f"{'checkout':<20}{'case':<14}{'N':>6}" + "".join(f"{r + ' s':>12}{'it':>4}" for r in RUNS)
            + f"{'re/first':>10}{'warm/first':>11}{'warm it/re it':>15}")
    print(head + "\n" + "-" * len(head))
    for name in cases:
        for N in steps:
            rows = {c: [] for c in args.checkouts}
            for _ in range(args.repeat):
                for checkout in args.checkouts:         # interleaved: all see the same load
                    out = subprocess.run([sys.executable, __file__, "--one", name, str(N)], check=True,
                                         env={**os.environ, "PYTHONPATH": checkout},
                                         capture_output=True, text=True).stdout.split()
                    rows[checkout].append([float(v) for v in out])
            for checkout in args.checkouts:
                best = np.min(rows[checkout], axis=0)
                seconds, its = best[0::2], best[1::2]
                print(f"{pathlib.Path(checkout).name:<20}{name:<14}{N:>6}"
                      + "".join(f"{s:>12.4f}{int(i):>4}" for s, i in zip(seconds, its))
                      + f"{seconds[1] / seconds[0]:>10.2f}{seconds[2] / seconds[0]:>11.2f}"
                      f"{its[2] / its[1]:>15.2f}")
    if args.sensitivities:
        sensitivity_rows(cases if args.smallest else (*cases, *BOUNDED), steps, max(args.repeat, 5))
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
