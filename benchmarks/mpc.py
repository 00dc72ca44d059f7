"""Benchmark: per-step times of the receding-horizon controller `dmoc.MPC` against the first
solve of the same problem structure, in one run.

The closed loop of examples/mpc_knife_edge.py: knife-edge parking over a horizon of
`--horizon` steps of h = 0.1 s (midpoint rule, variant "+"), the plant simulated by
`dmoc.simulate` with a 10 % heavier blade and a kick at step 10. Each fresh process runs
`--steps` controller steps: step 0 is the first solve of the structure (the solver is built,
default guess), every later step a warm start (the previous plan shifted, primal and dual,
on the kept solver). Two kinds of process: "warmed up" first solves an unrelated problem
(knife-edge parking at N = 20, so that loading IPOPT and CasADi's plugins is not counted in
step 0) and clears dmoc's caches; "fresh" starts the loop at once, as a script does.
Reported: for one warmed-up process the time `dmoc.MPC(problem)` takes to build the NLP
of the momentum start, and the per-step table (wall and CPU time of `MPC.step`, IPOPT's
wall share, iterations, ratios to step 0), then for `--repeat` processes of each kind the
first step (alone, and with the NLP's build), the median warm step, and their ratios.

    python benchmarks/mpc.py [--horizon 30] [--steps 40] [--repeat 3]
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402


def closed_loop(horizon, steps, warm_up):
    """The per-step records (dicts) of one closed loop, in this process."""
    if warm_up:
        dmoc.optimize(knife_edge_parking(20))       # load IPOPT and the plugins
        dmoc.clear_caches()
    problem = knife_edge_parking(horizon, duration=0.1 * horizon)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1), problem.disc.h)
    wall, cpu = time.perf_counter(), time.process_time()
    controller = dmoc.MPC(problem)          # builds the NLP of the momentum start
    build = {"step": time.perf_counter() - wall, "cpu": time.process_time() - cpu}
    q, p, cpu = np.zeros(3), np.zeros(3), []
    for k in range(steps):
        tic = time.process_time()
        u = controller.step(q, p=p)
        cpu.append(time.process_time() - tic)
        if k == 10:
            p = p + 0.3 * np.array([np.cos(q[2]), np.sin(q[2]), 1.0])
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
    return build, [{"step": r.step_time, "cpu": c, "ipopt": r.solve_time, "iterations": r.iterations,
                    "status": r.status, "warm": r.warm_start} for r, c in zip(controller.log, cpu)]


def table(records):
    first, first_cpu = records[0]["step"], records[0]["cpu"]
    print("| step | status | iterations | warm | wall [ms] | IPOPT wall [ms] | CPU [ms] | "
          "wall / first | CPU / first |")
    print("|---:|---|---:|---|---:|---:|---:|---:|---:|")
    for k, r in enumerate(records):
        print(f"| {k} | {r['status']} | {r['iterations']} | {r['warm']} | {1e3 * r['step']:.1f} | "
              f"{1e3 * r['ipopt']:.1f} | {1e3 * r['cpu']:.1f} | {r['step'] / first:.3f} | "
              f"{r['cpu'] / first_cpu:.3f} |")


def summary(build, records):
    parts = []
    for clock in ("step", "cpu"):
        first, built = records[0][clock], records[0][clock] + build[clock]
        warm = np.median([r[clock] for r in records[1:]])
        parts.append(f"{'wall' if clock == 'step' else 'CPU'}: first step {1e3 * first:.1f} ms, "
                     f"with the NLP's build {1e3 * built:.1f} ms; warm median {1e3 * warm:.1f} ms "
                     f"= {warm / first:.3f} x first step, {warm / built:.3f} x with the build")
    succeeded = all(r["status"] == "Solve_Succeeded" for r in records)
    return "; ".join(parts) + f"; all succeeded: {succeeded}"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--horizon", type=int, default=30)
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--child", choices=("warmed-up", "fresh"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(closed_loop(args.horizon, args.steps, args.child == "warmed-up")))
        return
    print(f"# {platform.platform()}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores; dmoc from {os.path.dirname(dmoc.__file__)}")
    print(f"# knife-edge MPC, horizon {args.horizon}, {args.steps} closed-loop steps\n")
    runs = {kind: [json.loads(subprocess.run(
        [sys.executable, __file__, "--child", kind, "--horizon", str(args.horizon), "--steps",
         str(args.steps)], capture_output=True, text=True, check=True).stdout)
        for _ in range(args.repeat)] for kind in ("warmed-up", "fresh")}
    build, records = runs["warmed-up"][0]
    print(f"building the NLP of the structure (dmoc.MPC(problem)): {1e3 * build['step']:.1f} ms "
          f"wall, {1e3 * build['cpu']:.1f} ms CPU\n")
    table(records)
    print()
    for kind, processes in runs.items():
        for i, (build, records) in enumerate(processes):
            print(f"{kind} process {i}: {summary(build, records)}")


if __name__ == "__main__":
    main()
