"""Benchmark: re-solving with new boundary data on a kept solver, dmoc against rockit's
parametric re-solve, at equal accuracy (issue 25; docs/performance.md, "Re-solves against
rockit").

On rolling-disk steering and knife-edge parking (J* from the issue) a scan finds, for dmoc
lobatto3 and lobatto4 and for rockit, the least N with |J_N - J*| / J* <= 1e-6 at the
original goal (doubling, then bisection). At that N each method solves the original goal
(its solver is built), then re-solves `--goals` goals near it in a cycle, each from the
previous optimum (primal and dual), `--repeat` times: median wall time per re-solve,
IPOPT's iterations, its wall time and the part in NLP function evaluations, NLP size.
dmoc is timed from the new goal: ``problem.with_boundary(q_goal=g)`` then
``dmoc.optimize(new, guess=previous)`` ("judged"), the same with ``check=False``
("unjudged"), the raw ``dmoc.optimal_control.solve`` ("raw"), or the raw solve with the NLP's
Functions expanded to SX (``expand=True``, "raw SX") or compiled to C (``jit=True``, "raw
C"), built when the original goal is solved, before the timing. rockit (not a dependency
of dmoc: run this script with the python of an environment that has rockit-meco and dmoc)
solves the reduced ODEs of `rockit_ocp` by multiple shooting (one RK4 step per interval,
piecewise-linear controls, the goal an ``ocp.parameter``, the NLP expanded), re-solved by
"solve": ``ocp.set_value``, the previous optimum set as the start of rockit's Opti,
``ocp.solve()`` (rockit's per-signal ``ocp.set_initial`` would re-transcribe the problem
at every solve), and "function": ``ocp.to_function`` of goal, start x and multipliers,
rockit's advice for repeated solves. With `--rockit-jit` also "function C": the same with
the NLP's Functions compiled to C by CasADi (nlpsol ``jit``, gcc -O2 as dmoc's
``jit=True``), the like-for-like peer of dmoc's "raw C" (rockit's "function" evaluates
expanded SX in CasADi's virtual machine, like dmoc's "raw SX"); compiling takes 20-40 s
per child process. IPOPT options as dmoc's defaults. "max dJ/J" is the largest relative
difference of a dmoc re-solve's cost from rockit's at the same goal. "IPOPT ms" is
CasADi's ``t_wall_total`` on both sides (dmoc's ``stats["ipopt_time"]``); for checkouts
from before that stat, dmoc's ``stats["solve_time"]``, the wall time of its packed nlpsol
call, which also holds the NumPy conversions of its inputs and outputs (about 0.1 ms):
there the column "IPOPT/" overstates dmoc's share by that much.

dmoc runs in a child process per checkout (``--checkouts A B``: PYTHONPATH set to each),
interleaved with rockit's child, `--rounds` times; per method the round of least time is
kept. Without rockit the script says so and exits.

    /work/venv-peers/bin/python benchmarks/peers_resolve.py [--repeat 5] [--rounds 3] [--checkouts DIR ...]
        [--rockit-jit]
"""

import argparse
import importlib.metadata
import inspect
import json
import os
import platform
import subprocess
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

ACCURACY = 1e-6
J_STAR = {"rolling disk": 1.02891883211, "knife edge": 8.72240586430}
GOAL = {"rolling disk": np.array([1.0, 1.0, np.pi / 2]),      # (x, y, heading phi)
        "knife edge": np.array([0.0, 1.0, 0.0])}              # (x, y, theta)
OFFSETS = np.array([[0.05, 0.0, 0.0], [0.0, 0.05, 0.05], [-0.05, 0.05, 0.0],
                    [0.05, -0.05, -0.05], [0.0, 0.1, 0.1], [-0.1, 0.0, 0.05]])
IPOPT = {"tol": 1e-10, "constr_viol_tol": 1e-10, "print_level": 0, "sb": "yes",
         "bound_relax_factor": 0.0, "mumps_permuting_scaling": 0, "mumps_pivot_order": 0,
         "linear_solver": "mumps", "max_iter": 1000}
DURATION = 4.0
# the reduced equations' inertias (along the path, turning): the knife edge's m = J = 1
# (s' = u0 / m, theta'' = u1 / J); the disk's m R^2 + I = 1 + 1/2 and J = m R^2 / 4 for
# m = R = 1 (the constraints x' = R cos(phi) theta', y' = R sin(phi) theta' in L give
# (m R^2 + I) theta'' = u0, J phi'' = u1)
REDUCED_INERTIA = {"knife edge": (1.0, 1.0), "rolling disk": (1.5, 0.25)}
DMOC_RULES = ("lobatto3", "lobatto4")
DMOC_RUNS = ("judged", "unjudged", "raw", "raw SX", "raw C")


def goals(name, count):
    """The original goal, then `count` goals near it, shape (count + 1, 3)."""
    return GOAL[name] + np.vstack([np.zeros(3), OFFSETS[:count]])


def least_n(cost_at, j_star, start):
    """Least N with |cost_at(N) - j_star| / j_star <= ACCURACY: doubling from `start`, then
    bisection; cost_at(N) is the optimum's cost at N steps."""
    def meets(N):
        return abs(cost_at(N) - j_star) / j_star <= ACCURACY
    low, high = start // 2, start
    while not meets(high):
        low, high = high, 2 * high
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if meets(mid) else (mid, high)
    return high


# ---- dmoc (run with PYTHONPATH at a checkout) --------------------------------------------

def dmoc_problem(name, N, rule, goal):
    """The dmoc.problems problem `name` at N steps with `rule`, moved to `goal`."""
    import dmoc.problems
    make = {"knife edge": dmoc.problems.knife_edge_parking,
            "rolling disk": dmoc.problems.rolling_disk_steering}[name]
    return moved(make(N, rule=rule, duration=DURATION), name, goal)


def moved(problem, name, goal):
    """`problem` with the goal `goal` = (x, y, heading) (with_boundary: same structure,
    kept solver; the rolling disk's rolling angle stays free)."""
    q_goal = list(goal) if name == "knife edge" else [goal[0], goal[1], None, goal[2]]
    return problem.with_boundary(q_goal=q_goal)


def cycle(step, targets, repeat):
    """Time `step(goal)` over `targets[1:]` then `targets[0]`, `repeat` times; step returns
    (iterations, IPOPT s, function s, cost). Returns ([median s, iterations, IPOPT s,
    function s], the first cycle's costs)."""
    seconds, rows = [], []
    for _ in range(repeat):
        for goal in list(targets[1:]) + [targets[0]]:
            tic = time.perf_counter()
            rows.append(step(goal))
            seconds.append(time.perf_counter() - tic)
    row = [float(np.median(seconds))] + np.median(np.array(rows)[:, :3], axis=0).tolist()
    return row, [r[3] for r in rows[:len(targets)]]


def dmoc_resolve(name, rule, N, repeat, count):
    """(this process) {run: [median seconds per re-solve, iterations, IPOPT s, function s]},
    the NLP size and the costs of dmoc's re-solves of `name` at N with `rule`."""
    import dmoc
    from dmoc.optimal_control.solver.solving import solve      # dmoc.optimize is the judged function
    targets = goals(name, count)
    problem = dmoc_problem(name, N, rule, targets[0])
    calls = {"judged": dmoc.optimize, "unjudged": lambda p, **k: dmoc.optimize(p, check=False, **k),
             "raw": solve}
    if "jit" in inspect.signature(solve).parameters:      # checkouts from before jit: no "raw C",
        calls["raw SX"] = lambda p, **k: solve(p, expand=True, **k)     # and expand=True
        calls["raw C"] = lambda p, **k: solve(p, jit=True, **k)         # expanded f and g only
    out = {"size": [problem.transcription.x_layout.size, problem.transcription.g_layout.size]}
    for run, call in calls.items():
        previous = call(problem, options={"print_level": 0})

        def step(goal):
            nonlocal previous
            previous = call(moved(problem, name, goal), guess=previous,
                            options={"print_level": 0})
            if not previous.success:
                raise RuntimeError(f"dmoc {rule} {run}: {previous.message}")
            st = previous.stats
            # IPOPT's time as CasADi records it, as for rockit (checkouts from before: the call's)
            return st["iterations"], st.get("ipopt_time", st["solve_time"]), st["function_time"], previous.cost
        out[run], out["costs"] = cycle(step, targets, repeat)
    return out


def dmoc_cost(name, rule):
    """N -> the raw solve's optimal cost at N steps with `rule`, at the original goal."""
    from dmoc.optimal_control.solver.solving import solve

    def cost_at(N):
        return solve(dmoc_problem(name, N, rule, GOAL[name]), options={"print_level": 0}).cost
    return cost_at


# ---- rockit ---------------------------------------------------------------------------

def rockit_ocp(name, N, jit=False):
    """(ocp, goal parameter) of rockit's problem `name` on N multiple-shooting intervals,
    minimizing int |u|^2 dt over 4 s from rest to rest at the goal (x, y, heading); with
    `jit` its NLP's Functions compiled to C by CasADi (gcc -O2).

    The reduced ODE, states (x, y, heading, speed along the path, turning rate), controls
    u continuous and piecewise linear (``ocp.control(2, order=1)``): knife edge, blade
    speed s and heading theta, s' = u0, theta'' = u1, (x, y)' = s (cos, sin)(theta);
    rolling disk, rolling rate w and heading phi, 1.5 w' = u0, 0.25 phi'' = u1,
    (x, y)' = w (cos, sin)(phi) (REDUCED_INERTIA); its rolling angle, free at the goal and
    in no equation, is left out. The start point bends heading and speed towards the goal
    (from all zeros the knife edge's sideways rows are singular and IPOPT stalls)."""
    import rockit
    ocp = rockit.Ocp(t0=0, T=DURATION)
    x, y, heading = ocp.state(), ocp.state(), ocp.state()
    speed, turn = ocp.state(), ocp.state()
    u = ocp.control(2, order=1)
    along, turning = REDUCED_INERTIA[name]
    ocp.set_der(x, speed * ca.cos(heading))    # R = 1 for the disk: (x, y)' = R w (cos, sin)
    ocp.set_der(y, speed * ca.sin(heading))
    ocp.set_der(speed, u[0] / along)
    ocp.set_der(heading, turn)
    ocp.set_der(turn, u[1] / turning)
    goal = ocp.parameter(3)
    for state in (x, y, heading, speed, turn):
        ocp.subject_to(ocp.at_t0(state) == 0)
    ocp.subject_to(ocp.at_tf(ca.vertcat(x, y, heading)) == goal)
    ocp.subject_to(ocp.at_tf(ca.vertcat(speed, turn)) == 0)
    ocp.add_objective(ocp.integral(ca.sumsqr(u)))
    bend = ca.sin(np.pi * ocp.t / DURATION)     # a start point off the singular rest: face the goal
    ocp.set_initial(heading, np.arctan2(GOAL[name][1], GOAL[name][0]) * bend)
    ocp.set_initial(speed, np.hypot(*GOAL[name][:2]) / DURATION * bend)
    compiled = {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O2"], "verbose": False}}
    ocp.solver("ipopt", {"print_time": False, "record_time": True, "expand": True, **(compiled if jit else {}),
                         "ipopt": {**IPOPT, "warm_start_init_point": "yes"}})
    ocp.method(rockit.MultipleShooting(N=N, M=1, intg="rk"))
    return ocp, goal


def rockit_solve(ocp, goal, value):
    """rockit's optimum for the goal `value` from the current initial guess."""
    ocp.set_value(goal, value)
    return ocp.solve()


def warm_start(ocp, sol):
    """Start the next solve from `sol`, primal and dual, through rockit's CasADi Opti
    (``ocp.set_initial`` per signal re-transcribes the problem: seconds per call)."""
    opti, found = ocp._method.opti, sol.sol.sol
    ca.Opti.set_initial(opti, found.value_variables())
    ca.Opti.set_initial(opti, opti.lam_g, found.value(opti.lam_g))


def rockit_cost(name):
    """N -> rockit's optimal cost at N intervals, at the original goal."""
    def cost_at(N):
        ocp, goal = rockit_ocp(name, N)
        return float(rockit_solve(ocp, goal, GOAL[name]).value(ocp.objective))
    return cost_at


def ipopt_figures(st):
    """(iterations, IPOPT wall s, of it in NLP functions) from CasADi nlpsol stats."""
    if not st["success"]:
        raise RuntimeError(f"rockit: {st['return_status']}")
    functions = sum(v for k, v in st.items() if k.startswith("t_wall_nlp_"))
    return st["iter_count"], st["t_wall_total"], functions


def rockit_resolve(name, N, repeat, count, jit=False):
    """(this process) rockit's re-solves, as `dmoc_resolve` returns them: runs "solve"
    (``set_value``, the warm start, ``ocp.solve()``) and "function" (rockit's
    ``ocp.to_function`` of goal, start x and multipliers, its advice for repeated solves);
    with `jit` also "function C", the function re-solve of the NLP compiled to C."""
    targets = goals(name, count)
    ocp, goal = rockit_ocp(name, N)
    sol = rockit_solve(ocp, goal, targets[0])
    opti = ocp._method.opti                  # the NLP's x and lam_g
    function = function_step(ocp, goal, sol)

    def solve_step(value):
        nonlocal sol
        warm_start(ocp, sol)
        sol = rockit_solve(ocp, goal, value)
        return (*ipopt_figures(sol.stats), float(sol.value(ocp.objective)))
    out = {"size": [opti.nx, opti.ng]}
    out["solve"], out["costs"] = cycle(solve_step, targets, repeat)
    out["function"], _ = cycle(function, targets, repeat)
    if jit:
        compiled, goal = rockit_ocp(name, N, jit=True)
        out["function C"], _ = cycle(function_step(compiled, goal, rockit_solve(compiled, goal, targets[0])),
                                     targets, repeat)
    return out


def function_step(ocp, goal, sol):
    """step(goal value) of rockit's function re-solve (``ocp.to_function`` of goal, start x
    and multipliers), started from its optimum `sol`."""
    opti = ocp._method.opti
    resolve = ocp.to_function("resolve", [goal, opti.x, opti.lam_g], [opti.x, opti.lam_g, opti.f])
    x, lam_g = sol.sol.sol.value(opti.x), sol.sol.sol.value(opti.lam_g)

    def step(value):
        nonlocal x, lam_g
        x, lam_g, cost = resolve(value, x, lam_g)
        return (*ipopt_figures(resolve.stats()), float(cost))
    return step


# ---- the run --------------------------------------------------------------------------

def child(checkout, *arguments):
    """The JSON that this script prints with `arguments` in a child process whose dmoc is
    `checkout`'s."""
    env = {**os.environ, "PYTHONPATH": checkout}
    out = subprocess.run([sys.executable, __file__, "--one", *arguments], check=True, env=env,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def one(argv):
    """(child) argv = [name, method, N, repeat, count]: print the re-solves as JSON; method
    "rockit-jit" is "rockit" with its "function C" run."""
    name, method, N, repeat, count = argv[0], argv[1], int(argv[2]), int(argv[3]), int(argv[4])
    if method.startswith("rockit"):
        print(json.dumps(rockit_resolve(name, N, repeat, count, jit=method == "rockit-jit")))
    else:
        print(json.dumps(dmoc_resolve(name, method, N, repeat, count)))


def scans():
    """{(name, method): N*} for every problem and method."""
    found = {}
    for name, j_star in J_STAR.items():
        for rule in DMOC_RULES:
            found[name, rule] = least_n(dmoc_cost(name, rule), j_star, 8)
        found[name, "rockit"] = least_n(rockit_cost(name), j_star, 16)
    return found


def least_loaded(outs):
    """Of several children's outputs for one method, per run the one of least median time
    (the round that the machine's other load disturbed least)."""
    best = dict(outs[0])
    for out in outs[1:]:
        for run, row in out.items():
            if run not in ("size", "costs") and row[0] < best[run][0]:
                best[run] = row
    return best


def table(name, n_star, measured, checkouts):
    """Print one problem's rows: per method (and checkout) and run, time, iterations, IPOPT
    and function seconds, the NLP size, the ratios to rockit's re-solves (solve, function,
    and function C when measured) and of IPOPT's time to rockit's function re-solve, and
    the largest cost difference from rockit's."""
    rock = measured["rockit"]
    runs = [run for run in ("solve", "function", "function C") if run in rock]
    head = (f"{'method':<10}{'checkout':<17}{'N':>4}{'x, g':>11}{'run':>11}{'ms':>8}{'it':>5}"
            f"{'IPOPT ms':>9}{'fun ms':>7}{'/solve':>7}{'/function':>10}"
            + (f"{'/C':>6}" if "function C" in runs else "") + f"{'IPOPT/':>7}{'max dJ/J':>9}")
    print(f"\n{name} (ratios: to rockit's {', '.join(runs)} re-solves; IPOPT's to rockit's "
          f"function)\n{head}\n" + "-" * len(head))
    rows = [("rockit", "", n_star[name, "rockit"], rock, run) for run in runs]
    rows += [(rule, os.path.basename(c), n_star[name, rule], measured[rule, c], run)
             for rule in DMOC_RULES for c in checkouts for run in DMOC_RUNS]
    for method, checkout, N, out, run in rows:
        if run not in out:
            continue
        s, it, ipopt, fun = out[run]
        gap = np.max(np.abs(np.subtract(out["costs"], rock["costs"])) / np.asarray(rock["costs"]))
        to_c = f"{s / rock['function C'][0]:>6.2f}" if "function C" in runs else ""
        print(f"{method:<10}{checkout:<17}{N:>4}{'%d, %d' % tuple(out['size']):>11}{run:>11}"
              f"{s * 1e3:>8.2f}{it:>5.1f}{ipopt * 1e3:>9.2f}{fun * 1e3:>7.2f}"
              f"{s / rock['solve'][0]:>7.2f}{s / rock['function'][0]:>10.2f}{to_c}"
              f"{ipopt / rock['function'][2]:>7.2f}{gap:>9.1e}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--one":
        one(argv[1:])
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="cycles of re-solves (default 5)")
    parser.add_argument("--rounds", type=int, default=3,
                        help="child processes per method and checkout; the least time is kept")
    parser.add_argument("--goals", type=int, default=5, help="goals near the original (<= 6)")
    parser.add_argument("--checkouts", nargs="+", default=[os.getcwd()],
                        help="dmoc checkouts to time (default: the current directory)")
    parser.add_argument("--rockit-jit", action="store_true",
                        help="also rockit's function re-solve compiled to C (20-40 s per child)")
    args = parser.parse_args(argv)
    try:
        import rockit  # noqa: F401
    except ImportError:
        print("rockit is not importable here: install it in a separate environment "
              "(pip install rockit-meco) and run this script with that python; skipped.")
        return
    print(f"python {platform.python_version()}, casadi {ca.__version__}, rockit "
          f"{importlib.metadata.version('rockit-meco')}; {os.cpu_count()} cores; load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()}")
    n_star = scans()
    print("least N with |J_N - J*| / J* <= 1e-6:", {f"{k[0]}, {k[1]}": v for k, v in n_star.items()})
    for name in J_STAR:
        counts = str(args.repeat), str(args.goals)
        rounds = []
        for _ in range(args.rounds):            # interleaved: all see the same load
            rockit = "rockit-jit" if args.rockit_jit else "rockit"
            rounds.append({"rockit": child(args.checkouts[0], name, rockit,
                                           str(n_star[name, "rockit"]), *counts)})
            for rule in DMOC_RULES:
                for checkout in args.checkouts:
                    rounds[-1][rule, checkout] = child(checkout, name, rule,
                                                       str(n_star[name, rule]), *counts)
        measured = {key: least_loaded([r[key] for r in rounds]) for key in rounds[0]}
        table(name, n_star, measured, args.checkouts)
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
