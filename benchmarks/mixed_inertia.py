"""Benchmark: knife-edge parking (0, 0, theta0) -> (0, 1, theta0) in 4 s, N = 100, from
headings theta0 = 0 and 0.3, with mass and yaw inertia of different orders, DMOC (the NLP
scaled by the inertia, `dmoc.optimal_control.nlp.scaling`) against the mapped trapezoidal and
Hermite-Simpson collocations of benchmarks/collocation.py with the same IPOPT options. Each
row: IPOPT iterations, status, the optimal cost (the problem has many local optima at these
ratios, so the methods may end in different ones), seconds, and for DMOC the largest
heading change per step and the largest of `dmoc.diagnostics.velocity_jumps` (of order 1
where the grid does not resolve the motion), and whether the simulator replays the optimum.

    python benchmarks/mixed_inertia.py
"""

import argparse
import os
import platform
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import collocation  # noqa: E402
import dmoc  # noqa: E402
from dmoc import diagnostics  # noqa: E402
from dmoc.systems import knife_edge  # noqa: E402

CASES = ((1.0, 1.0), (10.0, 1.0), (1e3, 1.0), (1.0, 1e-3), (1e4, 1.0), (1e6, 1e-3))
N, DURATION, HEADINGS = 100, 4.0, (0.0, 0.3)


def dmoc_row(mass, inertia, heading):
    disc = dmoc.discretize(knife_edge(mass=mass, inertia=inertia), DURATION / N)
    problem = dmoc.OptimalControlProblem(disc, N, q_start=[0.0, 0.0, heading],
                                      q_goal=[0.0, 1.0, heading])
    tic = time.perf_counter()
    result = dmoc.optimize(problem, throw=False)
    seconds = time.perf_counter() - tic
    q, p = result.trajectory.q, result.trajectory.p
    replay_q, replay_p = diagnostics.replay_error(problem, result)
    replays = replay_q <= 1e-8 * max(1.0, np.abs(q).max()) and replay_p <= 1e-8 * np.abs(p).max()
    return (result.stats["iterations"], result.status, result.cost, seconds,
            f"{np.abs(np.diff(q[:, 2])).max():.2f}",
            f"{diagnostics.velocity_jumps(result.trajectory).max():.2f}", "yes" if replays else "no")


def collocation_row(mass, inertia, heading, method):
    problem = collocation.knife_edge_problem(mass=mass, inertia=inertia, duration=DURATION,
                                             heading=heading)
    tic = time.perf_counter()
    r = collocation.solve(problem, N, method)
    return r.iterations, r.status, r.cost, time.perf_counter() - tic, "", "", ""


def main(argv=None):
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args(argv)
    print(f"python {platform.python_version()}, casadi {ca.__version__}; N = {N}; "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    head = (f"{'theta0':>7}{'m':>8}{'J':>8}  {'method':<16}{'it':>5}  {'status':<30}{'cost':>12}{'s':>8}"
            f"{'dtheta':>8}{'jump':>6}{'replay':>8}")
    print(head + "\n" + "-" * len(head))
    for heading in HEADINGS:
        for mass, inertia in CASES:
            rows = {"dmoc": dmoc_row(mass, inertia, heading),
                    **{method: collocation_row(mass, inertia, heading, method)
                       for method in ("trapezoid", "hermite_simpson")}}
            for name, (it, status, cost, seconds, turn, jump, replays) in rows.items():
                print(f"{heading:>7.1f}{mass:>8.0e}{inertia:>8.0e}  {name:<16}{it:>5}  {status:<30}{cost:>12.5g}"
                      f"{seconds:>8.3f}{turn:>8}{jump:>6}{replays:>8}")


if __name__ == "__main__":
    main()
