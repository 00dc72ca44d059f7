"""Benchmark: the NLP scaling and default guess that follow the units (each coordinate's
length in the motion, `dmoc.optimal_control.nlp.scaling.lengths`) and the path constraints at the
knots, against an earlier checkout, in one run. Each case is solved by both checkouts in
child processes, alternating, twice; a row gives IPOPT's iterations, status and cost for
each, and the ratio of their solve times (IPOPT's `solve_time`, the smaller of the two
rounds). Cases: the built-in problems (`dmoc.problems`, midpoint and lobatto3), knife-edge
parking stated in millimetres and kilometres (a cost in consistent units, so the optimum
is the SI one), the mixed-inertia blades of benchmarks/mixed_inertia.py, lane changes of
`dmoc.systems.car()` (1500 kg) and parking around a disc obstacle.

    python benchmarks/units.py                 # before = main
    python benchmarks/units.py <git revision>  # before = that revision
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROUNDS = 2


def _parking_in(unit):
    """Knife-edge parking (0, 0, 0) -> (0, 1 m, 0) in 4 s, N = 100, lengths in `unit`
    metres: m = 1 kg, J = 1 kg m^2 = unit^-2 kg unit^2, cost (F/N)^2 + (tau/N m)^2."""
    import dmoc
    s = 1.0 / unit
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=s * s), 0.04)
    return dmoc.OptimalControlProblem(disc, 100, q_start=[0, 0, 0], q_goal=[0, s, 0],
                                      running_cost=lambda q, v, u: (u[0] / s) ** 2 + (u[1] / s ** 2) ** 2)


def _blade(mass, inertia):
    import dmoc
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=mass, inertia=inertia), 0.04)
    return dmoc.OptimalControlProblem(disc, 100, q_start=[0, 0, 0.3], q_goal=[0, 1, 0.3])


def _car(goal, duration, steps):
    import dmoc
    disc = dmoc.discretize(dmoc.systems.car(), duration / steps)
    return dmoc.OptimalControlProblem(disc, steps, q_start=[0, 0, 0, 0], q_goal=goal)


def _disc_obstacle():
    import casadi as ca
    import dmoc
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    return dmoc.OptimalControlProblem(
        disc, 40, q_start=[0, 0, 0], q_goal=[0, 1, 0],
        path_constraints=lambda q, v, u: 0.2 ** 2 - ca.sumsqr(q[:2] - ca.DM([0.0, 0.5])))


def cases():
    """{name: a function building the problem}."""
    from dmoc import problems
    return {
        "knife_edge_parking(100)": lambda: problems.knife_edge_parking(100),
        "knife_edge_parking(50, lobatto3)": lambda: problems.knife_edge_parking(50, rule="lobatto3"),
        "rolling_disk_steering(100)": lambda: problems.rolling_disk_steering(100),
        "rolling_disk_steering(50, lobatto3)": lambda: problems.rolling_disk_steering(50, rule="lobatto3"),
        "parking in mm": lambda: _parking_in(1e-3),
        "parking in km": lambda: _parking_in(1e3),
        "blade m 1e3, J 1": lambda: _blade(1e3, 1.0),
        "blade m 1, J 1e-3": lambda: _blade(1.0, 1e-3),
        "car to (40, 3.5), 3 s, N 60": lambda: _car([40, 3.5, 0, 0], 3.0, 60),
        "car to (40, 3.5), 6 s, N 120": lambda: _car([40, 3.5, 0, 0], 6.0, 120),
        "car to (20, 2), 10 s, N 100": lambda: _car([20, 2, 0, 0], 10.0, 100),
        "car to (5, 5, pi/2), 10 s, N 100": lambda: _car([5, 5, np.pi / 2, 0], 10.0, 100),
        "parking around a disc, N 40": _disc_obstacle,
    }


def child():
    """Solve every case with the dmoc on sys.path; print one JSON line per case."""
    import dmoc
    from dmoc import diagnostics
    for name, make in cases().items():
        result = dmoc.optimize(make(), throw=False)
        jump = float(diagnostics.velocity_jumps(result.trajectory).max())
        print(json.dumps({"case": name, "it": result.stats["iterations"], "status": result.status,
                          "cost": result.cost, "time": result.stats["solve_time"], "jump": jump}),
              flush=True)


def run(checkout):
    env = {**os.environ, "PYTHONPATH": checkout, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child"], env=env, cwd=checkout,
                         capture_output=True, text=True, check=True).stdout
    return {row["case"]: row for row in map(json.loads, out.splitlines())}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("revision", nargs="?", default="main", help="the checkout before (default main)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child()
    else:
        compare(args.revision)


def compare(revision):
    """Print the cases solved by `revision` (before) and this checkout (after)."""
    with tempfile.TemporaryDirectory() as before:
        archive = subprocess.run(["git", "-C", ROOT, "archive", revision], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", before], input=archive, check=True)
        rounds = [(run(before), run(ROOT)) for _ in range(ROUNDS)]
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", revision], capture_output=True,
                            text=True).stdout.strip()
    print(f"python {platform.python_version()}, {platform.machine()}, before = {revision} ({commit}), "
          f"after = {ROOT}; load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    head = (f"{'case':<36}{'it before':>10}{'it after':>9}  {'cost before':>13}{'cost after':>13}"
            f"{'jump b/a':>12}{'time a/b':>9}  status after")
    print(head + "\n" + "-" * len(head))
    for name in cases():
        b, a = rounds[0][0][name], rounds[0][1][name]
        ratio = min(r[1][name]["time"] for r in rounds) / min(r[0][name]["time"] for r in rounds)
        print(f"{name:<36}{b['it']:>10}{a['it']:>9}  {b['cost']:>13.6g}{a['cost']:>13.6g}"
              f"{b['jump']:>6.2f}/{a['jump']:<5.2f}{ratio:>9.2f}  {a['status']}")


if __name__ == "__main__":
    main()
