"""Benchmark: the time of a warm raw re-solve outside IPOPT, checkout against checkout
(issue 25; docs/performance.md, "The Python around IPOPT, third pass").

Each checkout runs in a child process of its own (PYTHONPATH set to it), the checkouts
alternating `--rounds` times; a child makes `--count` warm raw re-solves
``solve(problem.with_boundary(q_goal=g), guess=previous, jit=True)`` over the goals of
`resolve_outside.py` in a cycle (after 30 uncounted) on rolling-disk steering (lobatto4,
N = 11) and knife-edge parking (lobatto3, N = 28), and reports per re-solve the wall time
(with `with_boundary`) and IPOPT's own time (``stats["ipopt_time"]``, CasADi's
``t_wall_total``); "outside" is their difference. Medians over all rounds; the last
column is the ratio of each checkout's median to the first checkout's. Every child's
chain must give the same bits (x, lam_x, lam_g, cost and the stats that are not times),
asserted across checkouts. A second table times `with_boundary` alone (`--count` calls
per child, the goals in a cycle), also on the lane change of
`examples/lane_change_problem.py` (N = 30), whose path constraints are checked at the
given ends; the lbx of the last call must have the same bits across checkouts.

    python benchmarks/outside_checkouts.py --checkouts /work/main /work/wt-outside [--rounds 6] [--count 300]
"""

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from checkouts import add_checkouts, imported_dmoc

TIMES = ("build_time", "solve_time", "ipopt_time", "function_time")
PROBLEMS = ("rolling disk, lobatto4, N = 11", "knife edge, lobatto3, N = 28")


def resolves(name, count):
    """(child) {"wall", "ipopt": per re-solve seconds, "digest": of the chain's bits}."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from resolve_outside import warm_resolves
    wall, ipopt, digest = [], [], hashlib.sha256()
    for seconds, result in warm_resolves(name, 30 + count):
        wall.append(seconds)
        ipopt.append(result.stats["ipopt_time"])
        for array in (result.x, result.lam_x, result.lam_g, np.float64(result.cost)):
            digest.update(np.ascontiguousarray(array, dtype=float).tobytes())
        digest.update(repr(sorted((k, v) for k, v in result.stats.items() if k not in TIMES)).encode())
    return {"wall": wall[30:], "ipopt": ipopt[30:], "digest": digest.hexdigest()}


def boundaries(name, count):
    """(child) {"wall": seconds per `with_boundary` call, "digest": of the last lbx}."""
    import time
    from resolve_outside import CASES, OFFSETS
    if name == LANE:
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples"))
        from lane_change_problem import lane_change
        problem, goal, q_goal = lane_change(30), np.array([3.5, 0.0]), lambda g: [None, g[0], g[1], 0.0]
    else:
        make, goal, q_goal = CASES[name]
        problem = make()
    wall = []
    for i in range(30 + count):
        data = q_goal(goal + OFFSETS[i % len(OFFSETS)][1:1 + len(goal)] if name == LANE else
                      goal + OFFSETS[i % len(OFFSETS)])
        tic = time.perf_counter()
        moved = problem.with_boundary(q_goal=data)
        wall.append(time.perf_counter() - tic)
    return {"wall": wall[30:], "ipopt": [0.0] * count,
            "digest": hashlib.sha256(moved.transcription.lbx.tobytes()).hexdigest()}


LANE = "lane change, N = 30 (path constraints)"


def child(checkout, kind, name, count):
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", kind, name, str(count)],
                         env={**os.environ, "PYTHONPATH": checkout + os.pathsep + os.path.dirname(
                             os.path.abspath(__file__))},
                         cwd=tempfile.gettempdir(), capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def collect(args, kind, name):
    """{checkout: {"wall", "ipopt", "digest"}} over `args.rounds` rounds of children, the
    checkouts alternating; the digests asserted equal across checkouts."""
    runs = {c: {"wall": [], "ipopt": [], "digest": set()} for c in args.checkouts}
    for _ in range(args.rounds):
        for checkout in args.checkouts:
            got = child(checkout, kind, name, args.count)
            for key in ("wall", "ipopt"):
                runs[checkout][key] += got[key]
            runs[checkout]["digest"].add(got["digest"])
    digests = set.union(*(r["digest"] for r in runs.values()))
    assert len(digests) == 1, f"{name}: the checkouts give different bits"
    return runs


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        run = resolves if argv[1] == "resolve" else boundaries
        print(json.dumps(run(argv[2], int(argv[3]))))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_checkouts(parser)
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--count", type=int, default=300)
    args = parser.parse_args(argv)
    for checkout in args.checkouts:
        print(f"{checkout}: {imported_dmoc(checkout)}")
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    print("\n| problem | checkout | ms | IPOPT ms | outside ms | outside / first |")
    print("|---|---|---:|---:|---:|---:|")
    for name in PROBLEMS:
        runs = collect(args, "resolve", name)
        first = None
        for checkout, run in runs.items():
            wall, ipopt = np.array(run["wall"]), np.array(run["ipopt"])
            outside = float(np.median(wall - ipopt))
            first = first or outside
            print(f"| {name} | {os.path.basename(checkout)} | {1e3 * np.median(wall):.3f} | "
                  f"{1e3 * np.median(ipopt):.3f} | {1e3 * outside:.3f} | {outside / first:.3f} |")
    print("\n| with_boundary | checkout | us | / first |")
    print("|---|---|---:|---:|")
    for name in PROBLEMS + (LANE,):
        runs = collect(args, "boundary", name)
        first = None
        for checkout, run in runs.items():
            us = 1e6 * float(np.median(run["wall"]))
            first = first or us
            print(f"| {name} | {os.path.basename(checkout)} | {us:.1f} | {us / first:.3f} |")
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end; the checkouts gave the same bits")


if __name__ == "__main__":
    main()
