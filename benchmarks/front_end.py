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
import statistics
import subprocess
import sys
import tempfile
import time

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


def run(checkout, arguments, out):
    """Wall time of one process, and the solve time its JSON summary reports (or None)."""
    env = {**os.environ, "PYTHONPATH": checkout, "MPLBACKEND": "Agg"}
    command = [sys.executable, *(a.replace("{out}", out) for a in arguments)]
    tic = time.perf_counter()
    subprocess.run(command, env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=out)     # not a checkout: -m puts cwd first
    wall = time.perf_counter() - tic
    summaries = list(pathlib.Path(out).glob("*_summary.json"))
    solve = None
    if summaries:
        data = json.loads(summaries[0].read_text())
        solve = data.get("solve_time") or data.get("wall_time")
    return wall, solve


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--checkouts", nargs="+",
                        default=[str(pathlib.Path(__file__).resolve().parents[1])])
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    for checkout in args.checkouts:
        found = subprocess.run([sys.executable, "-c", "import dmoc; print(dmoc.__file__)"],
                               env={**os.environ, "PYTHONPATH": checkout}, cwd=tempfile.gettempdir(),
                               capture_output=True, text=True, check=True).stdout.strip()
        print(f"{checkout}: dmoc from {found}")
    times = {(c, case): {"with": [], "without": [], "solve": []}
             for c in args.checkouts for case in CASES}
    for _ in range(args.repeat):
        for case, (full, bare) in CASES.items():
            for checkout in args.checkouts:          # interleaved: both see the same load
                with tempfile.TemporaryDirectory(prefix="dmoc-front-end-") as out:
                    wall, solve = run(checkout, full, out)
                    entry = times[checkout, case]
                    entry["with"].append(wall)
                    entry["solve"].append(solve)
                    entry["without"].append(run(checkout, bare, out)[0])
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end; medians of "
          f"{args.repeat} runs, seconds\n")
    print(f"{'checkout':24s} {'case':34s} {'with files':>10s} {'without':>8s} "
          f"{'front end':>9s} {'solve':>7s} {'front/without':>13s} {'front/solve':>11s}")
    for (checkout, case), entry in times.items():
        full, bare = statistics.median(entry["with"]), statistics.median(entry["without"])
        solves = [s for s in entry["solve"] if s is not None]
        solve = statistics.median(solves) if solves else float("nan")
        front = full - bare
        print(f"{pathlib.Path(checkout).name:24s} {case:34s} {full:10.2f} {bare:8.2f} "
              f"{front:9.2f} {solve:7.3f} {front / bare:13.2f} {front / solve:11.1f}")


if __name__ == "__main__":
    main()
