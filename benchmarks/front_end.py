"""Benchmark: what the command line costs beyond its solves. Each case runs as a fresh
process (`python -m dmoc ...`), as a user runs it, twice: with its files (plots, GIF) and
without them, the latter being the baseline timed in the same run (start-up, import, the
solves). `dmoc demo`'s baseline is a process doing the demo's simulations and solves alone.
Every pair runs alternately `--repeat` times; medians are printed with the ratio of the
front end (with - without) to the baseline and to the solve alone (IPOPT's time or the
simulator's, as the run reports it). Several checkouts (e.g. main and a branch) can be
compared in one run, interleaved:

    python benchmarks/front_end.py [--repeat 5] [--checkouts /work/main /work/wt-plots]
"""

import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import tempfile
import time

from checkouts import imported_dmoc

DEMO_SOLVES = """
import numpy as np, dmoc
from dmoc.cli.registry import BUILT_IN
for key, system in (("knife-edge", dmoc.systems.knife_edge(incline=0.2)),
                    ("rolling-disk", dmoc.systems.rolling_disk())):
    disc = dmoc.discretize(system, 10.0 / 1000)
    for variant in "+-":
        dmoc.simulate(disc, q0=BUILT_IN[key].start, v0=BUILT_IN[key].velocity, steps=1000,
                      variant=variant)
for make in (dmoc.problems.knife_edge_parking, dmoc.problems.rolling_disk_steering):
    for variant in "+-":
        dmoc.optimize(make(100, variant=variant))
"""

CASES = {   # name: (arguments with files, arguments without them)
    "demo": (["-m", "dmoc", "demo", "--out", "{out}"], ["-c", DEMO_SOLVES]),
    "optimize rolling-disk --animate": (
        ["-m", "dmoc", "optimize", "rolling-disk", "--out", "{out}", "--animate"],
        ["-m", "dmoc", "optimize", "rolling-disk"]),
    "optimize knife-edge --animate": (
        ["-m", "dmoc", "optimize", "knife-edge", "--out", "{out}", "--animate"],
        ["-m", "dmoc", "optimize", "knife-edge"]),
    "simulate knife-edge --animate": (
        ["-m", "dmoc", "simulate", "knife-edge", "--out", "{out}", "--animate"],
        ["-m", "dmoc", "simulate", "knife-edge"]),
}


def cpu_of_children():
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def run(checkout, arguments, out):
    """Wall and CPU time (user + system) of one process, and the solve time its JSON
    summary reports (or None). On a shared machine the CPU time is the steadier figure."""
    env = {**os.environ, "PYTHONPATH": checkout, "MPLBACKEND": "Agg"}
    command = [sys.executable, *(a.replace("{out}", out) for a in arguments)]
    tic, cpu = time.perf_counter(), cpu_of_children()
    subprocess.run(command, env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=out)     # not a checkout: -m puts cwd first
    wall, cpu = time.perf_counter() - tic, cpu_of_children() - cpu
    summaries = list(pathlib.Path(out).glob("*_summary.json"))
    solve = None
    if summaries:
        data = json.loads(summaries[0].read_text())
        solve = data.get("solve_time") or data.get("wall_time")
    return wall, cpu, solve


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--checkouts", nargs="+",
                        default=[str(pathlib.Path(__file__).resolve().parents[1])])
    args = parser.parse_args(argv)
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    for checkout in args.checkouts:
        found = imported_dmoc(checkout)
        print(f"{checkout}: dmoc from {found}")
    times = {(c, case): {k: [] for k in ("with", "without", "cpu with", "cpu without", "solve")}
             for c in args.checkouts for case in CASES}
    for _ in range(args.repeat):
        for case, (full, bare) in CASES.items():
            for checkout in args.checkouts:          # interleaved: both see the same load
                with tempfile.TemporaryDirectory(prefix="dmoc-front-end-") as out:
                    entry = times[checkout, case]
                    wall, cpu, solve = run(checkout, full, out)
                    entry["with"].append(wall)
                    entry["cpu with"].append(cpu)
                    entry["solve"].append(solve)
                    wall, cpu, _ = run(checkout, bare, out)
                    entry["without"].append(wall)
                    entry["cpu without"].append(cpu)
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end; medians of "
          f"{args.repeat} runs, seconds (wall, and CPU user + system)\n")
    print(f"{'checkout':10s} {'case':32s} {'with files':>10s} {'without':>8s} {'front end':>9s} "
          f"{'front/without':>13s} {'front/solve':>11s} {'CPU with':>8s} {'without':>8s} "
          f"{'front':>6s} {'solve':>6s}")
    for (checkout, case), entry in times.items():
        m = {k: statistics.median(v) for k, v in entry.items() if k != "solve"}
        solves = [s for s in entry["solve"] if s is not None]
        solve = statistics.median(solves) if solves else float("nan")
        front, cpu_front = m["with"] - m["without"], m["cpu with"] - m["cpu without"]
        print(f"{pathlib.Path(checkout).name:10s} {case:32s} {m['with']:10.2f} "
              f"{m['without']:8.2f} {front:9.2f} {front / m['without']:13.2f} "
              f"{front / solve:11.1f} {m['cpu with']:8.2f} {m['cpu without']:8.2f} "
              f"{cpu_front:6.2f} {solve:6.3f}")


if __name__ == "__main__":
    main()
