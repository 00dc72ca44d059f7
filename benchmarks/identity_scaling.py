"""Benchmark: IPOPT's NLP scaling left out where it is the identity (issue 25;
docs/performance.md, "The re-solve, sixth pass"), in one process, before and after
alternating call by call.

On rolling-disk steering (lobatto4, N = 11) and knife-edge parking (lobatto3, N = 28),
two chains of warm raw re-solves ``solve(problem.with_boundary(q_goal=g), guess=previous,
jit=True)`` over `peers_resolve.py`'s goals in a cycle: one with IPOPT's
``nlp_scaling_method`` "gradient-based" given (before: IPOPT evaluates grad f and the
Jacobian at the start point to find scaling factors of 1) and one with dmoc's choice
(after: "none" where `dmoc.optimize.ipopt.data_options` finds the scaling the identity),
called in turn (which goes first alternating); medians per re-solve of the wall time,
IPOPT's (``stats["ipopt_time"]``), its function evaluations (``stats["function_time"]``)
and the time outside IPOPT. Every pair has the same bits (x, lam_x, lam_g, cost, every
stat but times and ``solver_reused``), asserted; the first solves (cold) are timed the
same way.

    python benchmarks/identity_scaling.py [--count 600]
"""

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import peers_resolve as peers  # noqa: E402
from dmoc.optimize.solve import solve  # noqa: E402

BEFORE = {"nlp_scaling_method": "gradient-based"}
CASES = {"rolling disk, lobatto4, N = 11": ("rolling disk", "lobatto4", 11),
         "knife edge, lobatto3, N = 28": ("knife edge", "lobatto3", 28)}


def same(a, b):
    """Assert the same bits and non-time stats (but whether a solver was reused)."""
    for name in ("x", "lam_x", "lam_g", "cost"):
        assert np.array_equal(np.asarray(getattr(a, name)).view(np.int64),
                              np.asarray(getattr(b, name)).view(np.int64)), name
    kept = [k for k in a.stats if not k.endswith("_time") and k != "solver_reused"]
    assert {k: a.stats[k] for k in kept} == {k: b.stats[k] for k in kept}


def chains(name, rule, N, count):
    """{figure: ([before], [after])} seconds per warm re-solve of the two chains, and the
    same of `count // 10` first solves."""
    targets = peers.goals(name, 5)
    problem = peers.dmoc_problem(name, N, rule, targets[0])
    options = (BEFORE, {})
    previous = [solve(problem, jit=True, options=o) for o in options]
    moved = [peers.moved(problem, name, g) for g in list(targets[1:]) + [targets[0]]]
    warm = {k: ([], []) for k in ("wall", "ipopt", "functions")}
    for i in range(30 + count):
        for k in ((0, 1) if i % 2 else (1, 0)):
            tic = time.perf_counter()
            result = solve(moved[i % len(moved)], guess=previous[k], jit=True, options=options[k])
            seconds = time.perf_counter() - tic
            previous[k] = result
            if i >= 30:
                for key, value in (("wall", seconds), ("ipopt", result.stats["ipopt_time"]),
                                   ("functions", result.stats["function_time"])):
                    warm[key][k].append(value)
        same(*previous)
    cold = {k: ([], []) for k in ("wall", "ipopt", "functions")}
    for i in range(count // 10):
        results = [None, None]
        for k in ((0, 1) if i % 2 else (1, 0)):
            tic = time.perf_counter()
            results[k] = solve(moved[i % len(moved)], jit=True, options=options[k])
            seconds = time.perf_counter() - tic
            for key, value in (("wall", seconds), ("ipopt", results[k].stats["ipopt_time"]),
                               ("functions", results[k].stats["function_time"])):
                cold[key][k].append(value)
        same(*results)
    return warm, cold


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=600, help="re-solves per chain and problem")
    args = parser.parse_args()
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start\n")
    print("| problem | solve | IPOPT's scaling | ms | IPOPT ms | of it functions ms | outside ms "
          "| ms / before | IPOPT / before |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|")
    for label, case in CASES.items():
        for kind, times in zip(("warm re-solve", "first solve"), chains(*case, args.count)):
            med = {key: [float(np.median(t)) for t in times[key]] for key in times}
            outside = [float(np.median(np.subtract(w, i))) for w, i in zip(times["wall"], times["ipopt"])]
            for k, how in enumerate(("gradient-based (before)", "none where the identity (after)")):
                print(f"| {label if kind.startswith('warm') and k == 0 else ''} | {kind if k == 0 else ''} "
                      f"| {how} | {1e3 * med['wall'][k]:.3f} | {1e3 * med['ipopt'][k]:.3f} | "
                      f"{1e3 * med['functions'][k]:.3f} | {1e3 * outside[k]:.3f} | "
                      f"{med['wall'][k] / med['wall'][0]:.3f} | {med['ipopt'][k] / med['ipopt'][0]:.3f} |")
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end; the same bits in every pair")


if __name__ == "__main__":
    main()
