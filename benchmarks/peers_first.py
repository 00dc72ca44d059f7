"""Benchmark: a first solve at equal accuracy, dmoc against rockit, in one process
(docs/performance.md, "First solves against rockit").

On rolling-disk steering and knife-edge parking (J* of `peers_resolve.py`), each method
at the least N whose optimum is within 1e-6 of J* (the scans recorded in "Re-solves
against rockit": rolling disk lobatto3 31, lobatto4 11, rockit 42; knife edge lobatto3 28,
lobatto4 14, rockit 62) builds its problem and solves it from its default start, as a new
process would: dmoc with every cache emptied first (`dmoc.clear_caches`: the step
residual, the NLP's terms and derivatives and the IPOPT solver are built anew),
``dmoc.optimize(problem)`` with its defaults (the verdict included: "judged") and the raw
``dmoc.optimal_control.solve`` ("raw"); rockit's `peers_resolve.rockit_ocp` (multiple shooting,
one RK4 step per interval, piecewise-linear controls, its NLP expanded to SX) and
``ocp.solve()``. No method compiles to C. The methods run in turn, the one that goes first
turning round by round; per method the median and least wall time over `--repeat`
rounds, the iterations, the relative cost error against J*, and the ratio of the medians
to rockit's. rockit is not a dependency of dmoc: run this script with the python of an
environment that has rockit-meco and dmoc.

    /work/venv-peers/bin/python benchmarks/peers_first.py [--repeat 15] [--problem disk|knife|both]
"""

import argparse
import importlib.util
import os
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import peers_resolve as peers  # noqa: E402

# the least N within 1e-6 of J* (docs/performance.md, "Re-solves against rockit")
LEAST_N = {"rolling disk": {"lobatto3": 31, "lobatto4": 11, "rockit": 42},
           "knife edge": {"lobatto3": 28, "lobatto4": 14, "rockit": 62}}
PROBLEMS = {"disk": ("rolling disk",), "knife": ("knife edge",), "both": ("rolling disk", "knife edge")}


def dmoc_first(name, rule, N, judged):
    """first() -> (seconds, iterations, cost): dmoc's problem `name` at N steps with
    `rule` built and solved from its default guess after `dmoc.clear_caches`, judged
    (``dmoc.optimize``) or raw (``dmoc.optimal_control.solve``)."""
    import dmoc
    from dmoc.optimal_control.solver.solving import solve

    def first():
        dmoc.clear_caches()
        tic = time.perf_counter()
        problem = peers.dmoc_problem(name, N, rule, peers.GOAL[name])
        result = dmoc.optimize(problem) if judged else solve(problem)
        seconds = time.perf_counter() - tic
        if not result.success:
            raise RuntimeError(f"dmoc {rule}: {result.message}")
        return seconds, result.stats["iterations"], result.cost
    return first


def rockit_first(name, N):
    """first() -> (seconds, iterations, cost): rockit's problem `name` on N intervals
    built and solved (`peers_resolve.rockit_ocp`, ``ocp.solve()``)."""
    def first():
        tic = time.perf_counter()
        ocp, goal = peers.rockit_ocp(name, N)
        sol = peers.rockit_solve(ocp, goal, peers.GOAL[name])
        seconds = time.perf_counter() - tic
        return seconds, sol.stats["iter_count"], float(sol.value(ocp.objective))
    return first


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=15, help="rounds (default 15)")
    parser.add_argument("--problem", choices=PROBLEMS, default="both")
    args = parser.parse_args(argv)
    if importlib.util.find_spec("rockit") is None:
        print("rockit is not installed in this environment: nothing to compare (see the docstring).")
        return
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at start")
    for name in PROBLEMS[args.problem]:
        n = LEAST_N[name]
        methods = {f"dmoc {rule} {how}, N = {n[rule]}": dmoc_first(name, rule, n[rule], how == "judged")
                   for rule in ("lobatto3", "lobatto4") for how in ("judged", "raw")}
        methods[f"rockit, N = {n['rockit']}"] = rockit_first(name, n["rockit"])
        names, rows = list(methods), {m: [] for m in methods}
        for k in range(args.repeat):
            for method in names[k % len(names):] + names[:k % len(names)]:
                rows[method].append(methods[method]())
        base = float(np.median([r[0] for r in rows[names[-1]]]))
        print(f"\n{name}, J* = {peers.J_STAR[name]}: first solve, build included ({args.repeat} rounds)")
        print(f"{'method':<34}{'median ms':>10}{'least ms':>10}{'it':>4}{'|J - J*| / J*':>15}{'/ rockit':>10}")
        for method in names:
            seconds = np.array([r[0] for r in rows[method]])
            _, iterations, cost = rows[method][-1]
            error = abs(cost - peers.J_STAR[name]) / peers.J_STAR[name]
            print(f"{method:<34}{np.median(seconds) * 1e3:>10.1f}{seconds.min() * 1e3:>10.1f}"
                  f"{iterations:>4}{error:>15.2e}{np.median(seconds) / base:>10.3f}")
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
