"""Benchmark: DMOC (dmoc.OptimalControlProblem + dmoc.optimize, midpoint rule, variant "+")
against plain CasADi trapezoidal and Hermite-Simpson collocation of the reduced ODE
(benchmarks/collocation.py), on knife-edge parallel parking (A) and the rolling disk (B).

For every method and N it measures build time (problem construction + nlpsol creation;
the model itself, dmoc's MechanicalSystem and the baselines' ODE Function, is built
before the clock starts),
solve time (IPOPT wall), iterations, cost, the cost error against a reference (Hermite-
Simpson at N_ref = 3200, its own error estimated by Richardson against N_ref/2), and the
final-state error of the optimal controls re-simulated on the continuous reduced ODE
(scipy DOP853, rtol = atol = 1e-12, interval by interval, controls interpolated as each
method defines them). Every method runs with and without ``expand`` (MX graph vs SX).

    python benchmarks/dmoc_vs_collocation.py            # N in 25 ... 1600
    python benchmarks/dmoc_vs_collocation.py --quick    # N in 25, 50, 100
    python benchmarks/dmoc_vs_collocation.py --smallest # N = 25 once, reference at N = 200: a smoke run
"""

import argparse
import os
import platform
import time
from dataclasses import dataclass

# One BLAS thread for every method alike: on a small shared machine, OpenBLAS threads
# spinning next to MUMPS add noise, not speed (override by setting the variables).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import dmoc  # noqa: E402
import collocation  # noqa: E402
from collocation import IPOPT_OPTIONS  # noqa: E402

FULL_STEPS = (25, 50, 100, 200, 400, 800, 1600)
QUICK_STEPS = (25, 50, 100)
REFERENCE_STEPS = 3200
REFERENCE_OPTIONS = {"tol": 1e-13, "constr_viol_tol": 1e-13}
"""The reference alone is solved tighter: with tol = 1e-10 the cost of an NLP with ~10^4
defect rows is only good to ~1e-8 (sum of multiplier x residual), the floor seen in the
Hermite-Simpson rows at large N."""
METHODS = ("dmoc", "trapezoid", "hermite_simpson")
LABELS = {"dmoc": "dmoc", "trapezoid": "trap", "hermite_simpson": "hs"}


@dataclass(frozen=True)
class Case:
    """One benchmark problem: the reduced problem for collocation and its dmoc twin."""

    label: str
    reduced: collocation.ReducedProblem
    system: object          # () -> dmoc.MechanicalSystem
    q_start: tuple
    q_goal: tuple


CASES = (
    Case("A knife edge", collocation.knife_edge_problem(),
         lambda: dmoc.systems.knife_edge(mass=1.0, inertia=1.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    Case("B rolling disk", collocation.rolling_disk_problem(),
         lambda: dmoc.systems.rolling_disk(), (0.0, 0.0, 0.0, 0.0), (1.0, 1.0, None, np.pi / 2)),
)


@dataclass
class Run:
    """One solve: timings (seconds, best of the repeats), outcome and control pieces."""

    method: str
    expand: bool
    steps: int
    construct_time: float
    nlpsol_time: float
    solve_time: float
    iterations: int
    cost: float
    success: bool
    n_variables: int
    control_pieces: np.ndarray   # (N, d+1, nu), see collocation.CollocationResult
    system_time: float = float("nan")     # dmoc only: the system's construction, not in build

    @property
    def build_time(self):
        return self.construct_time + self.nlpsol_time

    @property
    def name(self):
        return f"{LABELS[self.method]}-{'sx' if self.expand else 'mx'}"


def solve_dmoc(case, steps, expand):
    """DMOC on `steps` steps; build = discretize + OCP + nlpsol. The system is built before
    the clock starts, as the baselines' reduced ODE Function is (`Case.reduced`); its own
    time is kept apart (`Run.system_time`, the "(system)" column of the build split)."""
    T = case.reduced.duration
    tic = time.perf_counter()
    system = case.system()
    system_time = time.perf_counter() - tic
    tic = time.perf_counter()
    disc = dmoc.discretize(system, T / steps, "midpoint")
    ocp = dmoc.OptimalControlProblem(disc, steps, q_start=list(case.q_start),
                                     q_goal=list(case.q_goal), variant="+")
    construct_time = time.perf_counter() - tic
    res = dmoc.optimize(ocp, options=IPOPT_OPTIONS, expand=expand, throw=False)
    dmoc.clear_caches("solvers", "row_sums")    # every repeat builds its solver, as the baselines do
    u = res.trajectory.u
    return Run("dmoc", expand, steps, construct_time, res.stats["build_time"],
               res.stats["solve_time"], res.stats["iterations"], res.cost, res.success,
               ocp.x_layout.size, u[:, None, :], system_time)


def solve_collocation(case, steps, method, expand):
    r = collocation.solve(case.reduced, steps, method, expand=expand)
    return Run(method, expand, steps, r.construct_time, r.nlpsol_time, r.solve_time,
               r.iterations, r.cost, r.success, r.n_variables, r.control_pieces)


def best_of(repeat, solve, *args):
    """Solve `repeat` times; keep the last outcome with the minimum of each timing."""
    runs = [solve(*args) for _ in range(repeat)]
    best = runs[-1]
    for name in ("construct_time", "nlpsol_time", "solve_time", "system_time"):
        setattr(best, name, min(getattr(r, name) for r in runs))
    return best


def resimulate(problem, pieces):
    """x(T) of the reduced ODE from x_start under the piecewise-polynomial controls.

    pieces : (N, d+1, nu), control values at d+1 equally spaced nodes of each interval
    (d = 0: constant). Each interval is integrated separately with DOP853, rtol = atol =
    1e-12, so that no step straddles a control kink.
    """
    N, nodes, _ = pieces.shape
    h = problem.duration / N
    local = np.linspace(0.0, 1.0, nodes) if nodes > 1 else np.zeros(1)
    vander = np.vander(local, nodes, increasing=True)
    x = np.array(problem.x_start, dtype=float)
    for k in range(N):
        coef = np.linalg.solve(vander, pieces[k]).tolist()    # u(s) = sum_i coef[i] s^i

        def fun(t, z, coef=coef):
            s = t / h
            u = [sum(c[j] * s**i for i, c in enumerate(coef)) for j in range(len(coef[0]))]
            return problem.rhs(z, u)

        sol = solve_ivp(fun, (0.0, h), x, method="DOP853", rtol=1e-12, atol=1e-12)
        x = sol.y[:, -1]
    return x


def final_errors(problem, x_final):
    """(|q(T) - q_goal| over the fixed configuration components, |w(T)| of the velocities)."""
    config = [i for i in problem.config if np.isfinite(problem.x_goal[i])]
    dq = x_final[config] - problem.x_goal[config]
    dv = x_final[list(problem.velocity)] - problem.x_goal[list(problem.velocity)]
    return float(np.linalg.norm(dq)), float(np.linalg.norm(dv))


def reference_cost(problem, steps):
    """Hermite-Simpson cost at `steps` and at steps/2 (IPOPT tol 1e-13); returns
    (J_ref, Richardson extrapolation J + (J - J_coarse)/15 for a fourth-order cost)."""
    fine = collocation.solve(problem, steps, "hermite_simpson", ipopt_options=REFERENCE_OPTIONS)
    coarse = collocation.solve(problem, steps // 2, "hermite_simpson",
                               ipopt_options=REFERENCE_OPTIONS)
    if not (fine.success and coarse.success):
        raise RuntimeError(f"reference solve failed: {fine.status}, {coarse.status}")
    return fine.cost, fine.cost + (fine.cost - coarse.cost) / 15.0


def warm_up(case):
    """Load IPOPT and the linear solver once, so no method pays for it in its timing."""
    solve_dmoc(case, 10, False)
    collocation.solve(case.reduced, 10, "trapezoid")


def run_case(case, steps_list, repeat):
    """All methods, both expand settings, all N, on one case; with re-simulation errors
    (once per method and N: the two expand settings give the same controls to round-off)."""
    runs = []
    for steps in steps_list:
        for expand in (False, True):
            for method in METHODS:
                if method == "dmoc":
                    run = best_of(repeat, solve_dmoc, case, steps, expand)
                else:
                    run = best_of(repeat, solve_collocation, case, steps, method, expand)
                twin = [r for r in runs if (r.method, r.steps) == (method, steps)]
                if twin and np.max(np.abs(twin[0].control_pieces - run.control_pieces)) < 1e-6:
                    run.dq, run.dv = twin[0].dq, twin[0].dv
                else:
                    run.dq, run.dv = final_errors(case.reduced,
                                                  resimulate(case.reduced, run.control_pieces))
                runs.append(run)
    return runs


def results_table(runs, J_ref):
    """Fixed-width table; ratios against the trapezoid run with the same N and expand."""
    head = (f"{'method':<8}{'N':>5}{'vars':>7}{'build s':>9}{'solve s':>9}{'it':>4}"
            f"{'cost':>15}{'|J-Jref|':>10}{'|dq(T)|':>10}{'|dv(T)|':>10}"
            f"{'build/tr':>9}{'solve/tr':>9}{'total/tr':>9}")
    lines = [head, "-" * len(head)]
    for steps in sorted({r.steps for r in runs}):
        for expand in (False, True):
            base = next(r for r in runs if (r.method, r.steps, r.expand) == ("trapezoid", steps, expand))
            for r in (r for r in runs if (r.steps, r.expand) == (steps, expand)):
                flag = "" if r.success else "  FAILED"
                lines.append(
                    f"{r.name:<8}{r.steps:>5}{r.n_variables:>7}{r.build_time:>9.4f}{r.solve_time:>9.4f}"
                    f"{r.iterations:>4}{r.cost:>15.10f}{abs(r.cost - J_ref):>10.2e}{r.dq:>10.2e}"
                    f"{r.dv:>10.2e}{r.build_time / base.build_time:>9.2f}"
                    f"{r.solve_time / base.solve_time:>9.2f}"
                    f"{(r.build_time + r.solve_time) / (base.build_time + base.solve_time):>9.2f}{flag}")
        lines.append("")
    return "\n".join(lines)


def build_table(runs):
    """Where build time goes, at the smallest and largest N: construction vs nlpsol."""
    head = (f"{'method':<8}{'N':>5}{'(system)':>10}{'construct':>11}{'nlpsol':>9}{'build':>9}")
    lines = [head, "-" * len(head)]
    for steps in (min(r.steps for r in runs), max(r.steps for r in runs)):
        for r in (r for r in runs if r.steps == steps):
            system = f"{r.system_time:>10.4f}" if r.method == "dmoc" else f"{'':>10}"
            lines.append(f"{r.name:<8}{r.steps:>5}{system}{r.construct_time:>11.4f}"
                         f"{r.nlpsol_time:>9.4f}{r.build_time:>9.4f}")
    return "\n".join(lines)


def precision_table(runs, targets=(1e-2, 1e-4, 1e-6, 1e-8)):
    """Work-precision: the smallest N reaching |dq(T)| <= target, and its build + solve."""
    head = f"{'method':<8}" + "".join(f"{'|dq|<=%.0e' % t:>20}" for t in targets)
    lines = [head, "-" * len(head)]
    for name in dict.fromkeys(r.name for r in runs):
        cells = []
        for target in targets:
            hit = [r for r in runs if r.name == name and r.dq <= target]
            r = min(hit, key=lambda r: r.steps) if hit else None
            cells.append(f"{'N=%d %.3fs' % (r.steps, r.build_time + r.solve_time):>20}" if r
                         else f"{'-':>20}")
        lines.append(f"{name:<8}" + "".join(cells))
    return "\n".join(lines)


def machine():
    threads = ", ".join(f"{v}={os.environ[v]}" for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"))
    return (f"python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
            f"scipy {__import__('scipy').__version__}, {platform.machine()}, {os.cpu_count()} CPUs, "
            f"{threads}")


def load():
    return "load average %.2f %.2f %.2f" % os.getloadavg()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="N in {25, 50, 100} only")
    parser.add_argument("--smallest", action="store_true",
                        help="N = 25 once, the reference at N = 200 (a smoke run, no figure)")
    parser.add_argument("--repeat", type=int, default=3,
                        help="solves per configuration; timings are the minimum (default 3)")
    args = parser.parse_args(argv)
    steps_list = (25,) if args.smallest else QUICK_STEPS if args.quick else FULL_STEPS
    reference_steps = 200 if args.smallest else REFERENCE_STEPS
    args.repeat = 1 if args.smallest else args.repeat
    print(machine())
    print(f"{load()} at start")
    print(f"IPOPT options (all methods): {IPOPT_OPTIONS}; exact Hessian; MUMPS.")
    print("mx: expand=False (mapped MX graph); sx: expand=True (expanded to SX).")
    print("Ratios x/tr: against trapezoid with the same N and the same expand setting.\n")
    tic = time.perf_counter()
    for case in CASES:
        warm_up(case)
        J_ref, J_rich = reference_cost(case.reduced, reference_steps)
        runs = run_case(case, steps_list, args.repeat)
        print(f"=== Problem {case.label}: T = {case.reduced.duration:g}, minimize int |u|^2 dt ===")
        print(f"J_ref = {J_ref:.14f} (Hermite-Simpson, N = {reference_steps}, IPOPT tol 1e-13); "
              f"Richardson with N = {reference_steps // 2}: {J_rich:.14f}, "
              f"|difference| = {abs(J_ref - J_rich):.1e}\n")
        print(results_table(runs, J_ref))
        print("Build time split (seconds; (system) = dmoc's system, built before the clock "
              "starts as the baselines' ODE Function is, not in build):")
        print(build_table(runs) + "\n")
        print("Work-precision (smallest N in the run reaching the re-simulated |dq(T)|; build + solve):")
        print(precision_table(runs) + "\n")
    print(f"total wall time {time.perf_counter() - tic:.1f} s; {load()} at end")


if __name__ == "__main__":
    main()
