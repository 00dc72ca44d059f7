"""Benchmark: where a warm step of the receding-horizon controller `dmoc.MPC` spends its CPU
time, inside the closed loop (not in a hot loop of one call, where the caches of the
processor make every part 2-3x cheaper), for one or several checkouts.

The closed loop of benchmarks/mpc.py (knife-edge parking, horizon `--horizon` steps of
h = 0.1 s, midpoint rule, a plant 10 % heavier than the model), `--steps` warm steps with a
kick every 40 steps. The parts are timed by wrapping the functions `MPC.step` calls (the
same functions in every checkout; a part a checkout lacks is left out), with
`time.process_time`; nested parts are indented and included in their parent. Reported per
checkout: the median over `--repeat` fresh processes (interleaved across the checkouts, so
that they see the same load) of each part's mean CPU per warm step.

    python benchmarks/mpc_parts.py --checkouts /work/main /path/to/branch [--steps 240] [--repeat 5]
"""

import argparse
import collections
import functools
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from checkouts import add_checkouts  # noqa: E402

# (label, module, attribute path): what MPC.step calls, in the order it calls them
PARTS = (("with_boundary", "dmoc.optimal_control.statement.problem", "OptimalControlProblem.with_boundary"),
         ("  Transcription.with_bounds", "dmoc.optimal_control.nlp.transcription", "Transcription.with_bounds"),
         ("shifted", "dmoc.drivers.mpc", "shifted"),
         ("solve", "dmoc.drivers.mpc", "solve"),
         ("  start_point", "dmoc.optimal_control.solver.solving", "start_point"),
         ("  data_tolerances", "dmoc.optimal_control.solver.solving", "data_tolerances"),
         ("  solver lookup", "dmoc.optimal_control.solver.solving", "ipopt_solver"),
         ("  IPOPT call", "dmoc.optimal_control.solver.ipopt", "PackedSolver.__call__"),
         ("  IPOPT stats", "dmoc.optimal_control.solver.ipopt", "PackedSolver.stats"),
         ("  f, g at x", "dmoc.optimal_control.solver.solving", "_values_at_x"),
         ("  most_violated", "dmoc.optimal_control.solver.solving", "most_violated"),
         ("  trajectory_from_x", "dmoc.optimal_control.solver.solving", "trajectory_from_x"),
         ("    momenta", "dmoc.optimal_control.nlp.transcription", "Transcription.momenta"))


def wrap(spent, label, module, path):
    """Replace the attribute `path` of `module` by a timed wrapper adding to spent[label];
    False when the checkout has no such attribute."""
    owner = sys.modules[module]
    *parents, name = path.split(".")
    for parent in parents:
        owner = getattr(owner, parent, None)
    function = getattr(owner, name, None) if owner is not None else None
    if function is None:
        return False

    @functools.wraps(function)
    def timed(*args, **kwargs):
        tic = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent[label] += time.process_time() - tic
    setattr(owner, name, timed)
    return True


def closed_loop(horizon, steps):
    """{part: mean CPU seconds per warm step} of one closed loop in this process."""
    import dmoc
    import dmoc.optimal_control.solver.solving  # noqa: F401 (the module, for `wrap`)
    from dmoc.problems import knife_edge_parking

    spent = collections.defaultdict(float)
    found = [label for label, module, path in PARTS if wrap(spent, label, module, path)]
    problem = knife_edge_parking(horizon, duration=0.1 * horizon)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1), problem.disc.h)
    controller = dmoc.MPC(problem)
    q, p, total = np.zeros(3), np.zeros(3), 0.0
    for k in range(steps + 1):
        if k == 1:                  # step 0 builds the solver: not a warm step
            spent.clear()
            total = 0.0
        tic = time.process_time()
        u = controller.step(q, p=p)
        total += time.process_time() - tic
        if k % 40 == 10:
            p = p + 0.3 * np.array([np.cos(q[2]), np.sin(q[2]), 1.0])
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
    iterations = np.mean([r.iterations for r in controller.log[1:]])
    return {"MPC.step": total / steps, **{label: spent[label] / steps for label in found},
            "iterations": float(iterations), "final q": q.tolist()}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--horizon", type=int, default=30)
    parser.add_argument("--steps", type=int, default=240)
    parser.add_argument("--repeat", type=int, default=5)
    add_checkouts(parser)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(closed_loop(args.horizon, args.steps)))
        return
    print(f"# {os.cpu_count()} cores; load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    print(f"# knife-edge MPC, horizon {args.horizon}, {args.steps} warm steps per process, "
          f"median over {args.repeat} processes of the mean CPU per warm step [ms]\n")
    runs = {c: [] for c in args.checkouts}
    for _ in range(args.repeat):
        for checkout in args.checkouts:             # interleaved: all see the same load
            out = subprocess.run(
                [sys.executable, __file__, "--child", "--horizon", str(args.horizon), "--steps",
                 str(args.steps)], env={**os.environ, "PYTHONPATH": checkout},
                cwd=tempfile.gettempdir(), capture_output=True, text=True, check=True).stdout
            runs[checkout].append(json.loads(out))
    names = [pathlib.Path(c).name for c in args.checkouts]
    print(f"{'part':30s}" + "".join(f"{n:>14s}" for n in names))
    for label in ["MPC.step"] + [label for label, _, _ in PARTS]:
        cells = [np.median([r[label] for r in runs[c]]) if label in runs[c][0] else None
                 for c in args.checkouts]
        print(f"{label:30s}" + "".join(f"{'-':>14s}" if v is None else f"{1e3 * v:14.3f}" for v in cells))
    for checkout, name in zip(args.checkouts, names):
        first = runs[checkout][0]
        print(f"# {name}: mean iterations per warm step {first['iterations']:.3f}, final q {first['final q']}")
    print(f"# load average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
