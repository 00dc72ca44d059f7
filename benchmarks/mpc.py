"""Benchmark: per-step times of the receding-horizon controller `dmoc.MPC` against the first
solve of the same problem structure, in one run, for one or several checkouts.

The closed loop of examples/mpc_knife_edge.py: knife-edge parking over a horizon of
`--horizon` steps of h = 0.1 s (midpoint rule, variant "+"), the plant simulated by
`dmoc.simulate` with a 10 % heavier blade and a kick at step 10. Each fresh process runs
`--steps` controller steps: step 0 is the first solve of the structure (the IPOPT solver
is created, default guess), every later step a warm start (the previous plan shifted,
primal and dual, on the kept solver). Two kinds of process: "warmed up" first solves an
unrelated problem (knife-edge parking at N = 20, so that loading IPOPT and CasADi's
plugins is not counted in step 0) and clears dmoc's caches; "fresh" starts the loop at
once, as a script does. Reported: for one warmed-up process (of the last checkout) the
time `dmoc.MPC(problem)` takes to build the NLP of the momentum start, and the per-step
table (wall and CPU time of `MPC.step`, IPOPT's wall share, iterations, ratios to step
0); then for `--repeat` processes of each kind and checkout (interleaved, so that the
checkouts see the same load) the first step (alone, with the NLP's build, and without
the creation of the IPOPT solver it includes), the median warm step, and their ratios.

"default" rows run `dmoc.MPC(problem)` as each checkout defines it (the NLP expanded to
flat SX Functions; on checkouts from before issue 25, the MX graph). With `--mx` every
checkout whose `dmoc.MPC` takes `expand` also runs ``dmoc.MPC(problem, expand=False)``
("mx" rows, the MX graph in CasADi's virtual machine). With `--jit` every checkout whose
`dmoc.MPC` takes `jit` also runs the loop with
``dmoc.MPC(problem, jit=True)`` (the NLP's Functions compiled to C, "jit" rows). The
children share a compiled-code folder of their own (a new temporary DMOC_CACHE_DIR), into
which one uncounted warmed-up process compiles the library first: the seconds its step 0
spent creating the solver (compiling and loading) are reported as the compile time, and
every timed process finds the library in the cache (its step 0 loads it).

With `--sphere` every checkout whose `dmoc.MPC` takes a `GroupOptimalControlProblem` also
runs the Chaplygin sphere rolled to a quarter turn at (1, 0.5) over a horizon of
`--horizon` steps of h = 0.2 s ("sphere" rows, issue 43), the plant the model itself (each
step starts from the plan's knot 1: a rolling plant cannot restart `dmoc.simulate` from a
momentum), a kick of 0.3 on Omega at step 10.

With `--tracking` every checkout whose `dmoc.MPC` takes `references` also runs a tracking
controller ("tracking" rows): the plan of knife-edge parking over 4 s (N = 40, solved
before the clock starts) followed over the same horizon by a problem whose running and
terminal costs read the plan's configurations and controls as parameters per knot and per
step, `dmoc.MPC(problem, references=...)` moving their windows on at every step (new
entries of p, no new NLP), the plant and kick as above.

    python benchmarks/mpc.py [--horizon 30] [--steps 40] [--repeat 3] [--mx] [--jit] [--tracking] [--sphere]
    python benchmarks/mpc.py --checkouts /work/main /path/to/branch     # before/after
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402
from resolve import add_checkouts, imported_dmoc  # noqa: E402


SWITCHES = {"default": {}, "mx": {"expand": False}, "jit": {"jit": True}, "tracking": {}, "sphere": {}}


def controlled(horizon, mode):
    """(the controller's problem, the keywords of `dmoc.MPC`) of `mode`: the parking problem,
    or for "tracking" the plan's tracking problem and its references."""
    if mode != "tracking":
        return knife_edge_parking(horizon, duration=0.1 * horizon), SWITCHES[mode]
    import casadi as ca
    parking = knife_edge_parking(40)
    plan = dmoc.optimize(parking).trajectory
    problem = dmoc.OptimalControlProblem(
        parking.disc, horizon, q_start=plan.q[0], q_goal=[None] * 3, v_goal=[None] * 3,
        parameters={"q_ref": plan.q[np.minimum(np.arange(horizon + 1), 40)],
                    "u_ref": plan.u[np.minimum(np.arange(horizon), 39)]},
        running_cost=lambda q, v, u, w: 1e4 * ca.sumsqr(q - w["q_ref"]) + ca.sumsqr(u - w["u_ref"]),
        terminal_cost=lambda q, v, w: 1e4 * ca.sumsqr(q - w["q_ref"]))
    return problem, {"references": {"q_ref": plan.q, "u_ref": np.vstack([plan.u, np.zeros((1, 2))])}}


def rolled_sphere(horizon, steps, warm_up):
    """The per-step records of the sphere's closed loop (`--sphere`), as `closed_loop`."""
    from scipy.spatial.transform import Rotation
    if warm_up:
        dmoc.optimize(knife_edge_parking(20))
        dmoc.clear_caches()
    ball = dmoc.systems.chaplygin_sphere((1.0, 1.5, 2.5), 1.3, 0.7, torques=True)
    problem = dmoc.GroupOptimalControlProblem(
        dmoc.discretize(ball, 0.2), horizon, R_start=np.eye(3), x_start=[0, 0], x_goal=[1.0, 0.5],
        R_goal=Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix())
    wall, cpu = time.perf_counter(), time.process_time()
    controller = dmoc.MPC(problem)
    build = {"step": time.perf_counter() - wall, "cpu": time.process_time() - cpu}
    q, p, cpu = (np.eye(3), np.zeros(2)), np.zeros(5), []
    for k in range(steps):
        tic = time.process_time()
        controller.step(q, p=p)
        cpu.append(time.process_time() - tic)
        if k == 0:
            build["solver"] = controller.plan.stats["build_time"]
        traj = controller.plan.trajectory
        q, p = (traj.R[1], traj.x[1]), traj.p[1] + (0.3 * np.array([1.0, 0, 0, 0, 0]) if k == 10 else 0)
    return build, [{"step": r.step_time, "cpu": c, "ipopt": r.solve_time, "iterations": r.iterations,
                    "status": r.status, "warm": r.warm_start} for r, c in zip(controller.log, cpu)]


def closed_loop(horizon, steps, warm_up, mode="default"):
    """The per-step records (dicts) of one closed loop, in this process; `mode` a key of
    SWITCHES (the keywords of `dmoc.MPC`)."""
    if mode == "sphere":
        return rolled_sphere(horizon, steps, warm_up)
    if warm_up:
        dmoc.optimize(knife_edge_parking(20))       # load IPOPT and the plugins
        dmoc.clear_caches()
    problem, keywords = controlled(horizon, mode)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1), problem.disc.h)
    wall, cpu = time.perf_counter(), time.process_time()
    controller = dmoc.MPC(problem, **keywords)   # builds the NLP
    build = {"step": time.perf_counter() - wall, "cpu": time.process_time() - cpu}
    q, p, cpu = np.zeros(3), np.zeros(3), []
    for k in range(steps):
        tic = time.process_time()
        u = controller.step(q, p=p)
        cpu.append(time.process_time() - tic)
        if k == 0:      # the seconds step 0 spent creating the IPOPT solver
            build["solver"] = controller.plan.stats["build_time"]
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
    first, warm = records[0]["step"], np.median([r["step"] for r in records[1:]])
    parts.append(f"the first step's solver creation {1e3 * build['solver']:.1f} ms wall: warm "
                 f"= {warm / (first - build['solver']):.3f} x the first step without it (wall)")
    succeeded = all(r["status"] == "Solve_Succeeded" for r in records)
    return "; ".join(parts) + f"; all succeeded: {succeeded}"


def child(checkout, kind, args, mode="default"):
    """(build, records) of one fresh process of `checkout` (its dmoc on PYTHONPATH)."""
    out = subprocess.run(
        [sys.executable, __file__, "--child", kind, "--horizon", str(args.horizon), "--steps",
         str(args.steps), "--mode", mode], env={**os.environ, "PYTHONPATH": checkout},
        cwd=tempfile.gettempdir(), capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def medians(processes):
    """The medians over `processes` of the warm median CPU, the first step's CPU, their
    ratio (quartiles in brackets), the first step's solver creation, and the warm median
    over the first step without it (wall)."""
    warm = np.array([np.median([r["cpu"] for r in records[1:]]) for _, records in processes])
    first = np.array([records[0]["cpu"] for _, records in processes])
    ratio = warm / first
    bare = [np.median([r["step"] for r in records[1:]]) / (records[0]["step"] - build["solver"])
            for build, records in processes]
    return (f"warm CPU median {1e3 * np.median(warm):.2f} ms, first step CPU "
            f"{1e3 * np.median(first):.2f} ms, warm / first {np.median(ratio):.3f} "
            f"({np.quantile(ratio, 0.25):.3f}-{np.quantile(ratio, 0.75):.3f}); the first step's "
            f"solver creation {1e3 * np.median([b['solver'] for b, _ in processes]):.1f} ms wall, "
            f"warm / first without it (wall) {np.median(bare):.3f}")


def takes(checkout, switch):
    """Whether the `dmoc.MPC` of `checkout` takes the keyword `switch` (for "group": a
    problem on SO(3), its module `dmoc.drivers.group_horizon`)."""
    code = (f"import inspect, dmoc; print({switch!r} in inspect.signature(dmoc.MPC).parameters)"
            if switch != "group" else
            "import importlib.util as u; print(u.find_spec('dmoc.drivers.group_horizon') is not None)")
    return subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": checkout},
                          cwd=tempfile.gettempdir(), capture_output=True, text=True,
                          check=True).stdout.strip() == "True"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--horizon", type=int, default=30)
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=3)
    add_checkouts(parser)
    parser.add_argument("--jit", action="store_true", help="also run dmoc.MPC(problem, jit=True)")
    parser.add_argument("--mx", action="store_true",
                        help="also run dmoc.MPC(problem, expand=False) (the MX graph)")
    parser.add_argument("--tracking", action="store_true",
                        help="also run a tracking controller (references moved at every step)")
    parser.add_argument("--sphere", action="store_true",
                        help="also run the Chaplygin sphere's controller (on SO(3) x R^2)")
    parser.add_argument("--child", choices=("warmed-up", "fresh"), help=argparse.SUPPRESS)
    parser.add_argument("--mode", choices=SWITCHES, default="default", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(closed_loop(args.horizon, args.steps, args.child == "warmed-up", args.mode)))
        return
    if args.jit:        # the children's own compiled-code folder
        os.environ["DMOC_CACHE_DIR"] = tempfile.mkdtemp(prefix="dmoc-mpc-bench-")
    print(f"# {platform.platform()}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores; load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    for checkout in args.checkouts:
        found = imported_dmoc(checkout)
        print(f"# {checkout}: dmoc from {found}")
    print(f"# knife-edge MPC, horizon {args.horizon}, {args.steps} closed-loop steps\n")
    variants = [(c, "default") for c in args.checkouts]
    variants += [(c, mode) for mode, switch, wanted in (("mx", "expand", args.mx), ("jit", "jit", args.jit),
                                                        ("tracking", "references", args.tracking),
                                                        ("sphere", "group", args.sphere))
                 for c in args.checkouts if wanted and takes(c, switch)]
    for checkout, mode in variants:
        if mode == "jit":
            build, _ = child(checkout, "warmed-up", args, "jit")
            print(f"{checkout} jit: compiling and loading the NLP's library (step 0's solver "
                  f"creation, the cache folder empty): {build['solver']:.2f} s wall")
    runs = {(c, mode, kind): [] for c, mode in variants for kind in ("warmed-up", "fresh")}
    for _ in range(args.repeat):
        for kind in ("warmed-up", "fresh"):
            for checkout, mode in variants:          # interleaved: all see the same load
                runs[checkout, mode, kind].append(child(checkout, kind, args, mode))
    build, records = runs[variants[-1][0], variants[-1][1], "warmed-up"][0]
    print(f"building the NLP of the structure (dmoc.MPC(problem)): {1e3 * build['step']:.1f} ms "
          f"wall, {1e3 * build['cpu']:.1f} ms CPU\n")
    table(records)
    print()
    for (checkout, mode, kind), processes in runs.items():
        for i, (build, records) in enumerate(processes):
            print(f"{checkout} {mode} {kind} process {i}: {summary(build, records)}")
    print()
    for (checkout, mode, kind), processes in runs.items():
        print(f"{checkout} {mode} {kind}: {medians(processes)}")
    print(f"# load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
