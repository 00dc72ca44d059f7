"""Benchmark: work-precision of DMOC with every rule against Hermite-Simpson collocation,
on knife-edge parallel parking (A) and rolling-disk steering (B) of
benchmarks/dmoc_vs_collocation.py.

For each method, the least end-to-end time (build + solve, best of `--repeat`) over a
ladder of N that reaches BOTH |J - J_ref| <= target and a re-simulated final-configuration
error |dq(T)| <= target (the optimal controls, interpolated as the method defines them,
integrated on the continuous reduced ODE by DOP853, rtol = atol = 1e-12). Methods:

- dmoc-RULE-mx / -sx: `dmoc.OptimalControlProblem` + `dmoc.optimize` (variant "+") with
  the rule (midpoint, trapezoid: one control per step; lobatto3, lobatto4: controls at the
  stage nodes), expand False / True; time = discretize + problem + a fresh nlpsol + IPOPT
  (`reuse_solver=False`, as the collocations build theirs). dmoc-lobatto3-*-resolve: the
  same with the solver reused from the previous solve of the same structure, what a
  re-solve costs.
- hs-map-mx / -sx: separated Hermite-Simpson of the reduced ODE with one mapped interval
  Function (benchmarks/collocation.py), the way a careful CasADi user writes it.
- hs-opti: the same Hermite-Simpson written with `casadi.Opti` and one `subject_to` per
  interval in a Python loop, the way most users write it; time = building the Opti problem
  + `opti.solve()` (which creates the solver).

Every method uses the same IPOPT options (collocation.IPOPT_OPTIONS) and the same initial
configuration path (collocation.guess_path, dmoc's default guess).

    python benchmarks/work_precision.py                # target 1e-6
    python benchmarks/work_precision.py --target 1e-8
    python benchmarks/work_precision.py --smallest     # problem A, target 1e-2, reference N = 200: a smoke run
"""

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
import collocation  # noqa: E402
from collocation import IPOPT_OPTIONS  # noqa: E402
from dmoc_vs_collocation import (CASES, REFERENCE_STEPS, final_errors, load, machine,  # noqa: E402
                                 reference_cost, resimulate)

LADDERS = {
    "midpoint": (100, 200, 400, 800, 1600),
    "trapezoid": (100, 200, 400, 800, 1600),
    "lobatto3": (10, 15, 20, 25, 30, 40, 50, 60, 80),
    "lobatto4": (4, 5, 6, 8, 10, 12, 15, 20),
    "hs": (10, 15, 20, 25, 30, 40, 50, 60, 80, 100),
}


def solve_dmoc(case, steps, rule, expand, reuse=False):
    """(seconds, cost, control pieces (N, d+1, nu)) of one end-to-end DMOC solve: with a
    fresh IPOPT solver (as the collocations build theirs), or with `reuse` the solver of
    the previous solve of the same structure (a re-solve)."""
    system = case.system()      # before the clock, as the baselines' ODE Function is built
    tic = time.perf_counter()
    disc = dmoc.discretize(system, case.reduced.duration / steps, rule)
    ocp = dmoc.OptimalControlProblem(disc, steps, q_start=list(case.q_start),
                                     q_goal=list(case.q_goal))
    res = dmoc.optimize(ocp, options=IPOPT_OPTIONS, expand=expand, reuse_solver=reuse, throw=False)
    seconds = time.perf_counter() - tic
    return seconds, res.cost, res.success, control_pieces(res.trajectory)


def control_pieces(traj):
    """u(t) of a Trajectory sampled at d+1 equally spaced points of every step (d + 1 =
    its number of control nodes; the interpolant has degree d, so this is exact). The end
    point of a step is taken just inside it: `Trajectory.control` assigns a knot to the
    step that starts there."""
    nodes = len(traj.control_nodes)
    local = np.linspace(0.0, 1.0 - 1e-10, nodes) if nodes > 1 else np.full(1, 0.5)
    times = traj.t[:-1, None] + traj.h * local[None, :]
    return traj.control(times.ravel()).reshape(traj.steps, nodes, -1)


def solve_hs_map(case, steps, expand):
    tic = time.perf_counter()
    r = collocation.solve(case.reduced, steps, "hermite_simpson", expand=expand)
    return time.perf_counter() - tic, r.cost, r.success, r.control_pieces


def solve_hs_opti(case, steps):
    """Separated Hermite-Simpson with casadi.Opti, one subject_to per interval."""
    problem = case.reduced
    tic = time.perf_counter()
    N, h, F = steps, problem.duration / steps, problem.ode
    opti = ca.Opti()
    X, U = opti.variable(problem.nx, N + 1), opti.variable(problem.nu, N + 1)
    Xm, Um = opti.variable(problem.nx, N), opti.variable(problem.nu, N)
    cost = 0
    for k in range(N):
        f0, fm, f1 = F(X[:, k], U[:, k]), F(Xm[:, k], Um[:, k]), F(X[:, k + 1], U[:, k + 1])
        opti.subject_to(Xm[:, k] == (X[:, k] + X[:, k + 1]) / 2 + h / 8 * (f0 - f1))
        opti.subject_to(X[:, k + 1] == X[:, k] + h / 6 * (f0 + 4 * fm + f1))
        cost += h / 6 * (ca.sumsqr(U[:, k]) + 4 * ca.sumsqr(Um[:, k]) + ca.sumsqr(U[:, k + 1]))
    opti.minimize(cost)
    opti.subject_to(X[:, 0] == problem.x_start)
    for i in np.flatnonzero(np.isfinite(problem.x_goal)):
        opti.subject_to(X[int(i), N] == problem.x_goal[i])
    tau = np.linspace(0.0, 1.0, N + 1)
    opti.set_initial(X, collocation.guess_states(problem, tau).T)
    opti.set_initial(Xm, collocation.guess_states(problem, (tau[:-1] + tau[1:]) / 2).T)
    opti.solver("ipopt", {"print_time": False, "error_on_fail": False},
                dict(IPOPT_OPTIONS))
    sol = opti.solve_limited()
    seconds = time.perf_counter() - tic
    u, um = np.array(sol.value(U)).reshape(problem.nu, -1), np.array(sol.value(Um)).reshape(problem.nu, -1)
    pieces = np.stack([u[:, :-1].T, um.T, u[:, 1:].T], axis=1)
    return seconds, float(sol.value(cost)), bool(opti.stats()["success"]), pieces


def methods():
    """name -> (ladder, solve(case, N) -> (seconds, cost, success, pieces))."""
    out = {}
    for rule in ("midpoint", "trapezoid", "lobatto3", "lobatto4"):
        for expand in (False, True):
            out[f"dmoc-{rule}-{'sx' if expand else 'mx'}"] = (
                LADDERS[rule], lambda c, N, r=rule, e=expand: solve_dmoc(c, N, r, e))
    for expand in (False, True):
        out[f"dmoc-lobatto3-{'sx' if expand else 'mx'}-resolve"] = (
            LADDERS["lobatto3"], lambda c, N, e=expand: solve_dmoc(c, N, "lobatto3", e, reuse=True))
    for expand in (False, True):
        out[f"hs-map-{'sx' if expand else 'mx'}"] = (
            LADDERS["hs"], lambda c, N, e=expand: solve_hs_map(c, N, e))
    out["hs-opti"] = (LADDERS["hs"], solve_hs_opti)
    return out


def first_reaching(case, ladder, solve, J_ref, target, repeat):
    """(N, seconds, cost error, |dq(T)|) at the first N of the ladder meeting the target,
    or the last N tried with its errors and seconds = None."""
    for N in ladder:
        seconds, cost, success, pieces = solve(case, N)
        dq, _ = final_errors(case.reduced, resimulate(case.reduced, pieces))
        error = abs(cost - J_ref)
        if success and error <= target and dq <= target:
            seconds = min([seconds] + [solve(case, N)[0] for _ in range(repeat - 1)])
            return N, seconds, error, dq
    return N, None, error, dq


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--target", type=float, default=1e-6, help="error target (default 1e-6)")
    parser.add_argument("--repeat", type=int, default=3, help="timed solves at the N found (best kept)")
    parser.add_argument("--smallest", action="store_true",
                        help="problem A, target 1e-2, once, the reference at N = 200 (a smoke run)")
    args = parser.parse_args(argv)
    cases, reference_steps = (CASES[:1], 200) if args.smallest else (CASES, REFERENCE_STEPS)
    if args.smallest:
        args.target, args.repeat = 1e-2, 1
    print(machine())
    print(f"{load()} at start; target |J - J_ref| <= {args.target:g} and |dq(T)| <= {args.target:g}")
    tic = time.perf_counter()
    for case in cases:
        solve_dmoc(case, 10, "lobatto3", False)           # load IPOPT, build residuals
        collocation.solve(case.reduced, 10, "hermite_simpson")
        J_ref, _ = reference_cost(case.reduced, reference_steps)
        print(f"\n=== Problem {case.label}: J_ref = {J_ref:.14f} ===")
        found = {name: first_reaching(case, ladder, solve, J_ref, args.target, args.repeat)
                 for name, (ladder, solve) in methods().items()}
        best_map = min(s for n, (_, s, _, _) in found.items() if n.startswith("hs-map") and s)
        opti = found["hs-opti"][1]
        head = (f"{'method':<26}{'N':>6}{'seconds':>10}{'|J-Jref|':>10}{'|dq(T)|':>10}"
                f"{'/hs-map':>9}{'/hs-opti':>10}")
        print(head + "\n" + "-" * len(head))
        for name, (N, seconds, error, dq) in found.items():
            if seconds is None:
                print(f"{name:<26}{'>' + str(N):>6}{'-':>10}{error:>10.1e}{dq:>10.1e}   (not reached)")
                continue
            ratio_opti = f"{seconds / opti:>10.2f}" if opti else f"{'-':>10}"
            print(f"{name:<26}{N:>6}{seconds:>10.4f}{error:>10.1e}{dq:>10.1e}"
                  f"{seconds / best_map:>9.2f}{ratio_opti}")
        print("/hs-map: against the faster of hs-map-mx and hs-map-sx; /hs-opti: against hs-opti.")
    print(f"\ntotal wall time {time.perf_counter() - tic:.1f} s; {load()} at end")


if __name__ == "__main__":
    main()
