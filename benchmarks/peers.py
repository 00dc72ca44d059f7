"""Benchmark: dmoc against rockit and Drake at equal accuracy, a first solve, a re-solve
with new boundary data and IPOPT's solve alone, on rolling-disk steering and knife-edge
parking (J* of `J_STAR`).

The environment: rockit is not a dependency of dmoc. Run this script with the python of a
separate virtual environment holding dmoc and the peers, installed from PyPI::

    python3 -m venv venv-peers && venv-peers/bin/pip install -e . rockit-meco drake
    venv-peers/bin/python benchmarks/peers.py first|resolve

Without rockit the script runs the dmoc side alone and says that the peer side is skipped;
without Drake (``pydrake``) its first-solve rows are left out.

Each method runs at the least N whose optimum is within 1e-6 of J* (`LEAST_N`, found by
``--scan``: doubling, then bisection). rockit solves the reduced ODEs by multiple
shooting (`rockit_ocp`: one RK4 step per interval, piecewise-linear controls, its NLP
expanded to SX); IPOPT options as dmoc's defaults. Drake transcribes the same ODEs with its
``DirectCollocation`` (Hermite-Simpson on a ``SymbolicVectorSystem``, first-order-hold
controls; `drake_program`) and solves the one program with its IPOPT and with SNOPT.

- ``first``: each method builds its problem and solves it from its default start, as a
  new process would: dmoc with every cache emptied first (`dmoc.clear_caches`),
  ``dmoc.optimize`` ("judged", the verdict included), the raw solve ("raw") and
  ``dmoc.optimize(problem, accuracy=1e-6)`` from N = 10 ("accuracy"); rockit's
  ``ocp.solve()``; Drake's program built and solved by IPOPT and by SNOPT. Nothing is compiled to C. The methods run in turn, the one that goes
  first turning round by round; per method the median and least wall time over
  `--repeat` rounds and the ratio of the medians to rockit's. With two or more
  ``--checkouts``, dmoc's methods alone, in a child process per checkout and round (3
  solves of each per child after an untimed one; `--repeat` rounds, default 5), and the
  ratio of each checkout's median to the first checkout's.
- ``resolve``: each method solves the original goal (its solver is built), then re-solves
  `--goals` goals near it in a cycle, each from the previous optimum (primal and dual),
  `--repeat` times: median wall time per re-solve, the iterations, the NLP solver's wall
  time ("NLP ms": IPOPT's, CasADi's ``t_wall_total`` and dmoc's ``stats["ipopt_time"]``, or
  on dmoc's Newton re-solves of these equality-constrained problems ``stats["newton_time"]``), the part in NLP function
  evaluations, and dmoc's verdict (``stats["verdict_time"]``, "vrd ms", and its part of the
  re-solve, "vrd/ms"), and the median CPU time of the process per re-solve ("CPU ms"; its
  ratio to rockit's function re-solve, "CPU/fun", the figure to read on a loaded machine,
  where wall times measure the scheduler). dmoc is timed from the new goal (``problem.with_boundary(q_goal=g)``):
  ``dmoc.optimize`` ("judged"), with ``check=False`` ("unjudged"), the raw solve ("raw"),
  with ``expand=True`` ("raw SX") and ``jit=True`` ("raw C"). The first three are the
  defaults, which compile a re-solved structure (and the verdict's step) in background
  threads: they are timed once they have switched ("settled": the re-solves and seconds
  that took, in the same process, from a compiled-code cache that may hold the libraries). rockit re-solves by
  "solve" (``ocp.set_value``, the previous optimum set as the start of its Opti,
  ``ocp.solve()``) and "function" (``ocp.to_function`` of goal, start x and multipliers,
  rockit's advice for repeated solves); with `--rockit-jit` also "function C", compiled to
  C by CasADi (gcc -O2, 20-40 s per child), the like-for-like peer of dmoc's "raw C".
  Each method runs in a child process per checkout (``--checkouts``), interleaved,
  `--rounds` times; the round of least time is kept.

- ``mpc``: the knife edge's receding-horizon controller over `--horizon` steps of h =
  0.1 s (the closed loop of benchmarks/mpc.py: a plant 10 % heavier, a kick at step 10,
  `--steps` steps): dmoc's ``dmoc.MPC(problem)`` (the midpoint rule, its defaults; timed
  once a first loop has compiled the structure in the background) and rockit's
  controller on as many multiple-shooting intervals, ``ocp.to_function`` of the measured
  state, start x and multipliers (the previous optimum's, unshifted), each driving its
  own plant. Per controller, in children interleaved `--rounds` times: the median warm
  step (wall and CPU of the process), IPOPT's part, iterations; the least-loaded round is
  kept.

- ``nlp``: IPOPT's solve alone, the nlpsol call's CPU time (CasADi's ``t_proc_total``;
  dmoc's ``stats["ipopt_cpu_time"]``), each method's problem built and solved once
  untimed, then solved `--repeat` times from its default start (least and median):
  dmoc's raw solve with midpoint, lobatto3 and lobatto4, per checkout, and rockit's
  ``ocp.solve()``, (a) at each method's least N for 1e-6 (`LEAST_N`), with the ratio to
  rockit's, and (b) at N = `--sizes` (default 100, 200, 400, 800), with the exponent p
  of N^p fitted by least squares to the times and to the times per iteration. A child
  process per method and checkout.

``--smallest`` runs the rolling disk with lobatto4 only, once, in this process (the
controllers over 8 steps; ``nlp`` at N = 8 and 16).

    venv-peers/bin/python benchmarks/peers.py first [--repeat 15] [--problem disk|knife|both] [--checkouts DIR ...]
    venv-peers/bin/python benchmarks/peers.py resolve [--repeat 5] [--rounds 3] [--checkouts DIR ...] [--rockit-jit]
    venv-peers/bin/python benchmarks/peers.py mpc [--horizon 30] [--steps 40] [--rounds 3] [--checkouts DIR ...]
    venv-peers/bin/python benchmarks/peers.py nlp [--repeat 5] [--sizes N ...] [--checkouts DIR ...]
"""

import argparse
import importlib.metadata
import importlib.util
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
NLP_RULES = ("midpoint",) + DMOC_RULES      # the rules of ``nlp``, IPOPT's solve alone
SIZES = (100, 200, 400, 800)                # ``nlp``'s N by default
# the least N within 1e-6 of J* (``--scan`` finds them again)
LEAST_N = {"rolling disk": {"midpoint": 921, "lobatto3": 31, "lobatto4": 11, "rockit": 42, "drake": 28},
           "knife edge": {"midpoint": 3290, "lobatto3": 28, "lobatto4": 14, "rockit": 62, "drake": 32}}
# the peers this script compares when their modules import, and their PyPI distributions
PEER_MODULES = {"rockit": "rockit", "drake": "pydrake.planning"}
PEER_DISTRIBUTIONS = {"rockit": "rockit-meco", "drake": "drake"}
PROBLEMS = {"disk": ("rolling disk",), "knife": ("knife edge",), "both": ("rolling disk", "knife edge")}


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
    (iterations, IPOPT s, function s, verdict s, cost). Returns ([median s, iterations,
    IPOPT s, function s, verdict s, median CPU s of this process], the first cycle's
    costs)."""
    seconds, cpu, rows = [], [], []
    for _ in range(repeat):
        for goal in list(targets[1:]) + [targets[0]]:
            tic, tac = time.perf_counter(), time.process_time()
            rows.append(step(goal))
            seconds.append(time.perf_counter() - tic)
            cpu.append(time.process_time() - tac)
    row = [float(np.median(seconds))] + np.median(np.array(rows)[:, :4], axis=0).tolist()
    return row + [float(np.median(cpu))], [r[4] for r in rows[:len(targets)]]


def settled(call, problem, name, targets, previous, limit=120.0):
    """(the last optimum, [re-solves, seconds]) of re-solving `problem` at `targets` in a
    cycle from `previous` with `call` until dmoc's default has switched to what it does
    for re-solves of a structure (``stats["compiled"]`` and, where it applies,
    ``stats["light_verdict"]`` and ``stats["verdict_compiled"]``: made in background
    threads), at most `limit` s;
    [0, 0] on checkouts from before (no ``stats["compiled"]``)."""
    count, tic = 0, time.perf_counter()
    while "compiled" in previous.stats and time.perf_counter() - tic < limit and not (
            previous.stats["compiled"] and previous.stats.get("light_verdict", True)
            and previous.stats.get("verdict_compiled", True)):
        previous = call(moved(problem, name, targets[count % len(targets)]), guess=previous,
                        options={"print_level": 0})
        count += 1
        time.sleep(0.01)        # the threads' turn
    return previous, [count, time.perf_counter() - tic]


def dmoc_resolve(name, rule, N, repeat, count):
    """(this process) {run: [median seconds per re-solve, iterations, IPOPT s, function s]},
    the NLP size and the costs of dmoc's re-solves of `name` at N with `rule`."""
    import dmoc
    from dmoc.optimal_control import solve      # dmoc.optimize is the judged function
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
        if run in ("judged", "unjudged", "raw"):        # the defaults: steady state first
            previous, out[run + " settled"] = settled(call, problem, name, targets, previous)

        def step(goal):
            nonlocal previous
            previous = call(moved(problem, name, goal), guess=previous,
                            options={"print_level": 0})
            if not previous.success:
                raise RuntimeError(f"dmoc {rule} {run}: {previous.message}")
            st = previous.stats
            # the NLP solver's own time: IPOPT's as CasADi records it, as for rockit, or
            # Newton's on a Newton re-solve (checkouts from before: the call's)
            solver = st["newton_time"] if st.get("nlp_solver") == "newton" else st.get("ipopt_time", st["solve_time"])
            return (st["iterations"], solver, st["function_time"],
                    st.get("verdict_time", 0.0), previous.cost)
        out[run], out["costs"] = cycle(step, targets, repeat)
    return out


def dmoc_cost(name, rule):
    """N -> the raw solve's optimal cost at N steps with `rule`, at the original goal."""
    from dmoc.optimal_control import solve

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
        return (*ipopt_figures(sol.stats), 0.0, float(sol.value(ocp.objective)))
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
        return (*ipopt_figures(resolve.stats()), 0.0, float(cost))
    return step


# ---- Drake ----------------------------------------------------------------------------

def drake_program(name, N):
    """(program, initial guess) of Drake's problem `name` on N intervals: the reduced ODEs of
    `rockit_ocp` as a ``SymbolicVectorSystem``, transcribed by ``DirectCollocation``
    (Hermite-Simpson, first-order-hold controls, N equal steps of DURATION / N), from rest
    to rest at the goal; the cost the exact integral of |u|^2 over the piecewise-linear
    controls, h/3 (a^2 + a b + b^2) per interval and control (Drake's ``AddRunningCost``
    would integrate it by the trapezoidal rule, an error of order h^2); started on
    rockit's start point."""
    from pydrake.planning import DirectCollocation
    from pydrake.symbolic import Variable, cos, sin
    from pydrake.systems.primitives import SymbolicVectorSystem
    from pydrake.trajectories import PiecewisePolynomial
    x = [Variable(s) for s in ("x", "y", "heading", "speed", "turn")]
    u = [Variable("u0"), Variable("u1")]
    along, turning = REDUCED_INERTIA[name]
    f = [x[3] * cos(x[2]), x[3] * sin(x[2]), x[4], u[0] / along, u[1] / turning]
    system = SymbolicVectorSystem(state=x, input=u, dynamics=f)
    h = DURATION / N
    collocation = DirectCollocation(system, system.CreateDefaultContext(), N + 1, h, h)
    collocation.AddEqualTimeIntervalsConstraints()
    program = collocation.prog()
    rest_at_goal = np.r_[GOAL[name], 0.0, 0.0]
    program.AddBoundingBoxConstraint(np.zeros(5), np.zeros(5), collocation.initial_state())
    program.AddBoundingBoxConstraint(rest_at_goal, rest_at_goal, collocation.final_state())
    interval = 2 * h / 3 * np.array([[1.0, 0.5], [0.5, 1.0]])     # the Hessian of h/3 (a^2 + ab + b^2)
    for k in range(N):
        for i in range(2):
            program.AddQuadraticCost(interval, np.zeros(2),
                                     [collocation.input(k)[i], collocation.input(k + 1)[i]], is_convex=True)
    t = np.linspace(0.0, DURATION, N + 1)
    bend = np.sin(np.pi * t / DURATION)
    start = np.zeros((5, N + 1))
    start[2] = np.arctan2(GOAL[name][1], GOAL[name][0]) * bend
    start[3] = np.hypot(*GOAL[name][:2]) / DURATION * bend
    collocation.SetInitialTrajectory(PiecewisePolynomial(), PiecewisePolynomial.FirstOrderHold(t, start))
    return program


def drake_solve(program, solver):
    """(success, iterations or -1, cost) of `program` solved by Drake's "ipopt" (dmoc's IPOPT
    tolerances; Drake's IPOPT has no MUMPS, it uses its default SPRAL) or "snopt" (major
    optimality and feasibility tolerances 1e-10)."""
    from pydrake.solvers import IpoptSolver, SnoptSolver, SolverOptions
    chosen = {"ipopt": IpoptSolver, "snopt": SnoptSolver}[solver]()
    options = SolverOptions()
    settings = ({"tol": IPOPT["tol"], "constr_viol_tol": IPOPT["constr_viol_tol"], "print_level": 0}
                if solver == "ipopt" else
                {"Major optimality tolerance": 1e-10, "Major feasibility tolerance": 1e-10})
    for key, value in settings.items():
        options.SetOption(chosen.solver_id(), key, value)
    result = chosen.Solve(program, None, options)
    details = result.get_solver_details()
    iterations = getattr(details, "iteration_count", -1) if solver == "ipopt" else -1
    return result.is_success(), iterations, result.get_optimal_cost()


def drake_cost(name):
    """N -> Drake's optimal cost at N intervals (IPOPT), at the original goal."""
    def cost_at(N):
        return drake_solve(drake_program(name, N), "ipopt")[2]
    return cost_at


def drake_first(name, N, solver):
    """first() -> (seconds, iterations, cost): Drake's program `name` on N intervals built and
    solved by `solver` ("ipopt" or "snopt")."""
    def first():
        tic = time.perf_counter()
        success, iterations, cost = drake_solve(drake_program(name, N), solver)
        seconds = time.perf_counter() - tic
        if not success:
            raise RuntimeError(f"Drake {solver} at N = {N}: not solved")
        return seconds, iterations, cost
    return first


# ---- first solves ---------------------------------------------------------------------

def dmoc_first(name, rule, N, how):
    """first() -> (seconds, iterations, cost): dmoc's problem `name` at N steps with
    `rule` built and solved from its default guess after `dmoc.clear_caches`, `how`:
    "judged" (``dmoc.optimize``), "raw" (the unjudged solve) or "accuracy"
    (``dmoc.optimize(problem, accuracy=ACCURACY)``, the last level's iterations and cost)."""
    import dmoc
    from dmoc.optimal_control import solve

    def first():
        dmoc.clear_caches()
        tic = time.perf_counter()
        problem = dmoc_problem(name, N, rule, GOAL[name])
        result = (solve(problem) if how == "raw" else
                  dmoc.optimize(problem, accuracy=ACCURACY if how == "accuracy" else None))
        seconds = time.perf_counter() - tic
        if not result.success:
            raise RuntimeError(f"dmoc {rule}: {result.message}")
        return seconds, result.stats["iterations"], result.cost
    return first


def rockit_first(name, N):
    """first() -> (seconds, iterations, cost): rockit's problem `name` on N intervals
    built and solved (`rockit_ocp`, ``ocp.solve()``)."""
    def first():
        tic = time.perf_counter()
        ocp, goal = rockit_ocp(name, N)
        sol = rockit_solve(ocp, goal, GOAL[name])
        seconds = time.perf_counter() - tic
        return seconds, sol.stats["iter_count"], float(sol.value(ocp.objective))
    return first


def first_solves(names, rules, n_star, repeat, peers):
    """Print the first solves of `names`: dmoc with `rules` (judged, raw, and with
    ``accuracy=1e-6`` from N = 10), and the peers of `peers` ("rockit", "drake"); the
    ratios of each row's median to each peer's. The peers' modules are imported first,
    untimed (dmoc's already is)."""
    for peer in peers:
        importlib.import_module(PEER_MODULES[peer])
    for name in names:
        methods = dmoc_methods(name, rules, n_star)
        if "rockit" in peers:
            methods[f"rockit, N = {n_star[name, 'rockit']}"] = rockit_first(name, n_star[name, "rockit"])
        for solver in ("ipopt", "snopt") if "drake" in peers else ():
            methods[f"Drake {solver.upper()}, N = {n_star[name, 'drake']}"] = \
                drake_first(name, n_star[name, "drake"], solver)
        labels, rows = list(methods), {m: [] for m in methods}
        for k in range(repeat):
            for method in labels[k % len(labels):] + labels[:k % len(labels)]:
                rows[method].append(methods[method]())
        medians = {m: float(np.median([r[0] for r in rows[m]])) for m in labels}
        bases = [m for m in labels if not m.startswith("dmoc")]
        print(f"\n{name}, J* = {J_STAR[name]}: first solve, build included ({repeat} rounds)")
        print(f"{'method':<36}{'median ms':>10}{'least ms':>10}{'it':>4}{'|J - J*| / J*':>15}"
              + "".join(f"{'/ ' + b.split(',')[0]:>14}" for b in bases))
        for method in labels:
            seconds = np.array([r[0] for r in rows[method]])
            _, iterations, cost = rows[method][-1]
            error = abs(cost - J_STAR[name]) / J_STAR[name]
            print(f"{method:<36}{medians[method] * 1e3:>10.1f}{seconds.min() * 1e3:>10.1f}"
                  f"{iterations if iterations >= 0 else '-':>4}{error:>15.2e}"
                  + "".join(f"{medians[method] / medians[b]:>14.3f}" for b in bases))


def dmoc_methods(name, rules, n_star):
    """{label: first()} of dmoc's first solves of `name` with `rules`: judged and raw at the
    least N of `n_star`, and with ``accuracy=1e-6`` from N = 10 (`dmoc_first`)."""
    methods = {}
    for rule in rules:
        for how in ("judged", "raw", "accuracy"):
            N = 10 if how == "accuracy" else n_star[name, rule]
            methods[f"dmoc {rule} {how}, N = {N}"] = dmoc_first(name, rule, N, how)
    return methods


def dmoc_firsts(name, count):
    """(child) {label: [[seconds, iterations, cost], ...]}: `count` first solves of each of
    `dmoc_methods` (at `LEAST_N`) after one untimed, in turn."""
    n_star = {(name, method): N for method, N in LEAST_N[name].items()}
    methods = dmoc_methods(name, DMOC_RULES, n_star)
    for first in methods.values():
        first()
    rows = {label: [] for label in methods}
    for _ in range(count):
        for label, first in methods.items():
            rows[label].append(list(first()))
    return rows


def checkout_firsts(names, checkouts, repeat, count=3):
    """Print dmoc's first solves of `names` per checkout: `repeat` rounds, each a child
    process per checkout (`dmoc_firsts`, `count` solves per method; the order of the
    checkouts turning round by round); per method the median and least wall time and the
    ratio of each checkout's median to the first checkout's."""
    for name in names:
        rows = {c: {} for c in checkouts}
        for k in range(repeat):
            for c in checkouts[k % len(checkouts):] + checkouts[:k % len(checkouts)]:
                for label, runs in child(c, name, "first", str(count)).items():
                    rows[c].setdefault(label, []).extend(runs)
        print(f"\n{name}, J* = {J_STAR[name]}: dmoc's first solves by checkout "
              f"({repeat} rounds of {count}; ratio: median / {os.path.basename(checkouts[0])}'s)")
        print(f"{'method':<36}{'checkout':<17}{'median ms':>10}{'least ms':>10}{'it':>4}"
              f"{'|J - J*| / J*':>15}{'ratio':>8}")
        for label in rows[checkouts[0]]:
            base = np.median([r[0] for r in rows[checkouts[0]][label]])
            for c in checkouts:
                seconds = np.array([r[0] for r in rows[c][label]])
                _, iterations, cost = rows[c][label][-1]
                print(f"{label:<36}{os.path.basename(c):<17}{np.median(seconds) * 1e3:>10.1f}"
                      f"{seconds.min() * 1e3:>10.1f}{iterations:>4}"
                      f"{abs(cost - J_STAR[name]) / J_STAR[name]:>15.2e}{np.median(seconds) / base:>8.3f}")


# ---- re-solves --------------------------------------------------------------------------

def child(checkout, *arguments):
    """The JSON that this script prints with `arguments` in a child process whose dmoc is
    `checkout`'s."""
    env = {**os.environ, "PYTHONPATH": checkout}
    out = subprocess.run([sys.executable, __file__, "--one", *arguments], check=True, env=env,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def one(argv):
    """(child) argv = [name, method, N, repeat, count]: print the re-solves as JSON; method
    "rockit-jit" is "rockit" with its "function C" run; methods "rockit-mpc" and
    "dmoc-mpc" print a controller's warm steps (`rockit_mpc`, `dmoc_mpc`: N the horizon,
    repeat the steps). argv = [name, "first", count]: dmoc's first solves (`dmoc_firsts`);
    [name, "nlp", method, repeat, N ...]: IPOPT's solve alone (`nlp_rows`)."""
    if argv[1] == "first":
        print(json.dumps(dmoc_firsts(argv[0], int(argv[2]))))
        return
    if argv[1] == "nlp":        # [name, "nlp", method, repeat, N ...]
        print(json.dumps(nlp_rows(argv[0], argv[2], [int(N) for N in argv[4:]], int(argv[3]))))
        return
    name, method, N, repeat, count = argv[0], argv[1], int(argv[2]), int(argv[3]), int(argv[4])
    if method.endswith("-mpc"):     # N the horizon, repeat the steps
        print(json.dumps((rockit_mpc if method == "rockit-mpc" else dmoc_mpc)(N, repeat)))
    elif method.startswith("rockit"):
        print(json.dumps(rockit_resolve(name, N, repeat, count, jit=method == "rockit-jit")))
    else:
        print(json.dumps(dmoc_resolve(name, method, N, repeat, count)))


def scans(peers):
    """{(name, method): N*} for every problem and method (the peers' of `peers`)."""
    found = {}
    for name, j_star in J_STAR.items():
        for rule in NLP_RULES:
            found[name, rule] = least_n(dmoc_cost(name, rule), j_star, 8)
        if "rockit" in peers:
            found[name, "rockit"] = least_n(rockit_cost(name), j_star, 16)
        if "drake" in peers:
            found[name, "drake"] = least_n(drake_cost(name), j_star, 16)
    return found


def least_loaded(outs):
    """Of several children's outputs for one method, per run the one of least median time
    (the round that the machine's other load disturbed least)."""
    best = dict(outs[0])
    for out in outs[1:]:
        for run, row in out.items():
            if run not in ("size", "costs") and not run.endswith(" settled") and row[0] < best[run][0]:
                best[run] = row
    return best


def table(name, n_star, measured, checkouts, rules):
    """Print one problem's rows: per method (and checkout) and run, time, iterations, IPOPT,
    function and verdict seconds, the NLP size, and for dmoc's defaults the re-solves and
    seconds until they settled (`settled`); with rockit measured, the ratios to its
    re-solves (solve, function, and function C when measured), of the NLP solver's time to rockit's
    function re-solve, of the verdict to the re-solve, and the largest cost difference from
    rockit's."""
    rock = measured.get("rockit")
    runs = [run for run in ("solve", "function", "function C") if rock and run in rock]
    head = (f"{'method':<10}{'checkout':<17}{'N':>4}{'x, g':>11}{'run':>11}{'ms':>8}{'CPU ms':>7}{'it':>5}"
            f"{'NLP ms':>9}{'fun ms':>7}{'vrd ms':>7}{'vrd/ms':>7}{'settled':>11}"
            + "".join(f"{'/' + run:>12}" for run in runs)
            + (f"{'CPU/fun':>8}{'NLP/':>7}{'max dJ/J':>9}" if rock else ""))
    print(f"\n{name}" + (f" (ratios: to rockit's {', '.join(runs)} re-solves; the NLP solver's to "
                         "rockit's function's IPOPT)" if rock else "") + f"\n{head}\n" + "-" * len(head))
    rows = [("rockit", "", n_star[name, "rockit"], rock, run) for run in runs]
    rows += [(rule, os.path.basename(c), n_star[name, rule], measured[rule, c], run)
             for rule in rules for c in checkouts for run in DMOC_RUNS]
    for method, checkout, N, out, run in rows:
        if run not in out:
            continue
        s, it, ipopt, fun, verdict, cpu = (out[run] + [0.0, np.nan])[:6]     # outputs from before
        count, seconds = out.get(run + " settled", (0, 0.0))
        line = (f"{method:<10}{checkout:<17}{N:>4}{'%d, %d' % tuple(out['size']):>11}{run:>11}"
                f"{s * 1e3:>8.2f}{cpu * 1e3:>7.2f}{it:>5.1f}{ipopt * 1e3:>9.2f}{fun * 1e3:>7.2f}{verdict * 1e3:>7.2f}"
                f"{verdict / s:>7.2f}{'%d, %.1fs' % (count, seconds) if count else '':>11}")
        if rock:
            gap = np.max(np.abs(np.subtract(out["costs"], rock["costs"])) / np.asarray(rock["costs"]))
            line += "".join(f"{s / rock[r][0]:>12.2f}" for r in runs)
            line += f"{cpu / rock['function'][5]:>8.2f}{ipopt / rock['function'][2]:>7.2f}{gap:>9.1e}"
        print(line)


def resolves(names, rules, n_star, args, peers):
    """Print the re-solves of `names`, dmoc with `rules` per checkout and rockit's when
    "rockit" is in `peers` (Drake has no re-solve rows): in child processes, `args.rounds` times interleaved; with `args.smallest` once
    in this process."""
    counts = str(args.repeat), str(args.goals)
    for name in names:
        rounds = []
        for _ in range(args.rounds):            # interleaved: all see the same load
            rounds.append({})
            if "rockit" in peers:
                rockit = "rockit-jit" if args.rockit_jit else "rockit"
                rounds[-1]["rockit"] = child(args.checkouts[0], name, rockit,
                                             str(n_star[name, "rockit"]), *counts)
            for rule in rules:
                for checkout in args.checkouts:
                    rounds[-1][rule, checkout] = (
                        dmoc_resolve(name, rule, n_star[name, rule], args.repeat, args.goals)
                        if args.smallest else child(checkout, name, rule, str(n_star[name, rule]), *counts))
        measured = {key: least_loaded([r[key] for r in rounds]) for key in rounds[0]}
        table(name, n_star, measured, args.checkouts, rules)


# ---- MPC --------------------------------------------------------------------------------

PLANT = {"mass": 1.1}         # benchmarks/mpc.py's plant: 10 % heavier than the model
KICK = (10, 0.3)              # at step 10, 0.3 of a unit momentum along the blade and turning


def closed_loop(controller, horizon, steps):
    """(seconds of each controller step, IPOPT seconds, iterations, CPU seconds) of a closed loop of
    `steps` steps on the knife-edge plant (`PLANT`, `KICK`) from rest at the origin;
    ``controller(q, v) -> (u, IPOPT s, iterations)`` gives the control held over the step."""
    import dmoc
    plant = dmoc.discretize(dmoc.systems.knife_edge(**PLANT), 0.1)
    q, p, rows = np.zeros(3), np.zeros(3), []
    for k in range(steps):
        v = p / np.array([PLANT["mass"], PLANT["mass"], 1.0])
        tic, tac = time.perf_counter(), time.process_time()
        u, ipopt, iterations = controller(q, v)
        rows.append((time.perf_counter() - tic, ipopt, iterations, time.process_time() - tac))
        if k == KICK[0]:
            p = p + KICK[1] * np.array([np.cos(q[2]), np.sin(q[2]), 1.0])
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=np.asarray(u)[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
    return rows


def dmoc_mpc(horizon, steps):
    """(this process) [median warm step s, IPOPT s, iterations, CPU s] of ``dmoc.MPC`` on
    knife-edge parking over `horizon` steps, after closed loops of the same structure until
    its solves evaluate the compiled NLP (checkouts from before: one loop)."""
    import dmoc
    from dmoc.problems import knife_edge_parking
    problem = knife_edge_parking(horizon, duration=0.1 * horizon)

    def loop():
        mpc = dmoc.MPC(problem)

        def controller(q, v):
            u = mpc.step(q, v=v)
            return u, mpc.log[-1].solve_time, mpc.log[-1].iterations
        return mpc, closed_loop(controller, horizon, steps)
    mpc, rows = loop()
    tic = time.perf_counter()
    while "compiled" in mpc.plan.stats and not mpc.plan.stats["compiled"] and time.perf_counter() - tic < 120:
        mpc, rows = loop()
    mpc, rows = loop()
    return np.median(np.array(rows[1:]), axis=0).tolist()


def rockit_mpc(horizon, steps):
    """(this process) [median warm step s, IPOPT s, iterations, CPU s] of rockit's controller:
    `rockit_ocp`'s knife edge on `horizon` intervals over 0.1 `horizon` s, its start a
    parameter (x, y, heading, speed along the blade, turning rate), the goal (0, 1, 0) at
    rest, re-solved by ``ocp.to_function`` from the previous optimum; the control applied
    is the first interval's mean of its piecewise-linear u."""
    import rockit
    ocp = rockit.Ocp(t0=0, T=0.1 * horizon)
    x, y, heading, speed, turn = (ocp.state() for _ in range(5))
    u = ocp.control(2, order=1)
    ocp.set_der(x, speed * ca.cos(heading))
    ocp.set_der(y, speed * ca.sin(heading))
    ocp.set_der(speed, u[0])          # the model's m = J = 1
    ocp.set_der(heading, turn)
    ocp.set_der(turn, u[1])
    start, states = ocp.parameter(5), ca.vertcat(x, y, heading, speed, turn)
    ocp.subject_to(ocp.at_t0(states) == start)
    ocp.subject_to(ocp.at_tf(states) == ca.vertcat(GOAL["knife edge"], 0, 0))
    ocp.add_objective(ocp.integral(ca.sumsqr(u)))
    bend = ca.sin(np.pi * ocp.t / (0.1 * horizon))
    ocp.set_initial(heading, np.pi / 2 * bend)
    ocp.set_initial(speed, 1.0 / (0.1 * horizon) * bend)
    ocp.solver("ipopt", {"print_time": False, "record_time": True, "expand": True,
                         "ipopt": {**IPOPT, "warm_start_init_point": "yes"}})
    ocp.method(rockit.MultipleShooting(N=horizon, M=1, intg="rk"))
    ocp.set_value(start, np.zeros(5))
    sol = ocp.solve()
    opti = ocp._method.opti
    resolve = ocp.to_function("mpc", [start, opti.x, opti.lam_g],
                              [opti.x, opti.lam_g, ocp.sample(u, grid="control")[1]])
    found = {"x": sol.sol.sol.value(opti.x), "lam_g": sol.sol.sol.value(opti.lam_g)}

    def controller(q, v):
        along = v[0] * np.cos(q[2]) + v[1] * np.sin(q[2])
        found["x"], found["lam_g"], controls = resolve([q[0], q[1], q[2], along, v[2]],
                                                       found["x"], found["lam_g"])
        _, ipopt, _ = ipopt_figures(resolve.stats())
        return np.asarray(controls)[:, :2].mean(axis=1), ipopt, resolve.stats()["iter_count"]
    rows = closed_loop(controller, horizon, steps)
    return np.median(np.array(rows[1:]), axis=0).tolist()


def mpcs(args, peers):
    """Print the warm MPC steps of rockit (when `peers`) and of dmoc per checkout, measured
    in children interleaved `args.rounds` times (in this process with `args.smallest`)."""
    counts = [str(args.horizon), str(args.steps)]
    methods = (["rockit"] if peers else []) + args.checkouts
    best = {}
    for _ in range(args.rounds):
        for method in methods:
            checkout = args.checkouts[0] if method == "rockit" else method
            kind = "rockit-mpc" if method == "rockit" else "dmoc-mpc"
            if args.smallest:
                row = (rockit_mpc if method == "rockit" else dmoc_mpc)(args.horizon, args.steps)
            else:
                row = child(checkout, "knife edge", kind, *counts, "0")
            if method not in best or row[0] < best[method][0]:
                best[method] = row
    print(f"\nknife-edge MPC, horizon {args.horizon}, {args.steps} closed-loop steps: the median warm step")
    print(f"{'controller':<24}{'step ms':>9}{'CPU ms':>8}{'IPOPT ms':>10}{'it':>5}"
          + (f"{'/ rockit':>10}{'CPU /':>7}" if peers else ""))
    for method in methods:
        s, ipopt, it, cpu = best[method]
        label = "rockit to_function" if method == "rockit" else f"dmoc.MPC {os.path.basename(method)}"
        print(f"{label:<24}{s * 1e3:>9.2f}{cpu * 1e3:>8.2f}{ipopt * 1e3:>10.2f}{it:>5.1f}"
              + (f"{s / best['rockit'][0]:>10.2f}{cpu / best['rockit'][3]:>7.2f}" if peers else ""))


# ---- IPOPT's solve alone ------------------------------------------------------------------

def dmoc_nlp(name, rule, N):
    """(again, [n_x, n_g]): ``again() -> (CPU s, iterations, cost)`` of IPOPT's solve alone
    (``stats["ipopt_cpu_time"]``, CasADi's ``t_proc_total`` of the nlpsol call; the wall
    ``ipopt_time`` on checkouts from before) of dmoc's raw solve of `name` at N steps with
    `rule` from its default guess, the solver built by an untimed solve first."""
    from dmoc.optimal_control import solve
    problem = dmoc_problem(name, N, rule, GOAL[name])
    solve(problem)

    def again():
        result = solve(problem)
        if not result.success:
            raise RuntimeError(f"dmoc {rule} at N = {N}: {result.message}")
        st = result.stats
        return st.get("ipopt_cpu_time", st["ipopt_time"]), st["iterations"], result.cost
    T = problem.transcription
    return again, [T.x_layout.size, T.g_layout.size]


def rockit_nlp(name, N):
    """(again, [n_x, n_g]) as `dmoc_nlp` of rockit's multiple shooting (`rockit_ocp`): IPOPT's
    solve alone (``t_proc_total``) of ``ocp.solve()`` from rockit's start point, its
    transcription made by an untimed solve first."""
    ocp, goal = rockit_ocp(name, N)
    rockit_solve(ocp, goal, GOAL[name])
    opti = ocp._method.opti

    def again():
        sol = ocp.solve()
        iterations, _, _ = ipopt_figures(sol.stats)
        return sol.stats["t_proc_total"], iterations, float(sol.value(ocp.objective))
    return again, [opti.nx, opti.ng]


def nlp_rows(name, method, sizes, repeat):
    """(this process) {N: [least CPU s, median CPU s, iterations, cost, n_x, n_g]} of IPOPT's
    solve alone for `method` (a rule of NLP_RULES or "rockit") at each N of `sizes`,
    `repeat` solves each."""
    rows = {}
    for N in sizes:
        again, size = rockit_nlp(name, N) if method == "rockit" else dmoc_nlp(name, method, N)
        runs = [again() for _ in range(repeat)]
        seconds = [r[0] for r in runs]
        rows[N] = [min(seconds), float(np.median(seconds)), runs[-1][1], runs[-1][2], *size]
    return rows


def slope(sizes, seconds):
    """The least-squares slope of log(seconds) against log(sizes): the exponent p of
    seconds ~ N^p."""
    return float(np.polyfit(np.log(sizes), np.log(seconds), 1)[0])


def nlp_solves(names, n_star, args, peers):
    """Print IPOPT's solve alone (CPU, least of `args.repeat`; median; iterations; per
    iteration) of dmoc's rules (`NLP_RULES`, per checkout) and rockit's multiple shooting
    (when in `peers`): (a) at each method's least N for 1e-6 (`n_star`), with the ratio to
    rockit's; (b) at each N of `args.sizes`, with the exponent of N (`slope`) of the
    time and of the time per iteration. In a child process per method and checkout (in this
    process with `args.smallest`); with several checkouts, the ratio to the first's."""
    rules = ("lobatto4",) if args.smallest else NLP_RULES
    methods = [(rule, c) for rule in rules for c in args.checkouts]
    methods += [("rockit", args.checkouts[0])] if "rockit" in peers else []
    for name in names:
        measured = {}
        for method, checkout in methods:
            for part, sizes in (("least", [n_star[name, method]]), ("sizes", args.sizes)):
                counts = [str(args.repeat), *map(str, sizes)]
                rows = (nlp_rows(name, method, sizes, args.repeat) if args.smallest
                        else {int(k): v for k, v in child(checkout, name, "nlp", method, *counts).items()})
                measured[method, checkout, part] = rows
        print(f"\n{name}: IPOPT's solve alone, CPU (least of {args.repeat}; median), at the least N "
              f"for 1e-6" + ("; ratios of the least to rockit's" if "rockit" in peers else ""))
        print(f"{'method':<10}{'checkout':<14}{'N':>6}{'x, g':>14}{'it':>4}{'CPU ms':>9}{'median':>9}"
              f"{'ms/it':>8}{'|J - J*| / J*':>15}" + (f"{'/ rockit':>10}" if "rockit" in peers else "")
              + (f"{'/ first':>9}" if len(args.checkouts) > 1 else ""))
        for method, checkout in methods:
            (N, row), = measured[method, checkout, "least"].items()
            least, median, it, cost, n_x, n_g = row
            line = (f"{method:<10}{os.path.basename(checkout) if method != 'rockit' else '':<14}{N:>6}"
                    f"{'%d, %d' % (n_x, n_g):>14}{it:>4}{least * 1e3:>9.2f}{median * 1e3:>9.2f}"
                    f"{least / it * 1e3:>8.3f}{abs(cost - J_STAR[name]) / J_STAR[name]:>15.2e}")
            if "rockit" in peers:
                rock = measured["rockit", args.checkouts[0], "least"]
                line += f"{least / next(iter(rock.values()))[0]:>10.2f}"
            if len(args.checkouts) > 1 and method != "rockit":
                first = measured[method, args.checkouts[0], "least"][N][0]
                line += f"{least / first:>9.2f}"
            print(line)
        print(f"\n{name}: IPOPT's solve alone over N, CPU ms (least of {args.repeat}) [iterations]; "
              "the exponent p of N^p by least squares, of the time and of the time per iteration")
        print(f"{'method':<10}{'checkout':<14}" + "".join(f"{'N = %d' % N:>16}" for N in args.sizes)
              + f"{'p':>7}{'p per it':>9}" + (f"{'/ first':>9}" if len(args.checkouts) > 1 else ""))
        for method, checkout in methods:
            rows = measured[method, checkout, "sizes"]
            seconds = np.array([rows[N][0] for N in args.sizes])
            its = np.array([rows[N][2] for N in args.sizes])
            line = (f"{method:<10}{os.path.basename(checkout) if method != 'rockit' else '':<14}"
                    + "".join(f"{'%.2f [%d]' % (s * 1e3, it):>16}" for s, it in zip(seconds, its))
                    + f"{slope(args.sizes, seconds):>7.2f}{slope(args.sizes, seconds / its):>9.2f}")
            if len(args.checkouts) > 1 and method != "rockit":
                first = measured[method, args.checkouts[0], "sizes"]
                line += f"{seconds[-1] / first[args.sizes[-1]][0]:>9.2f}"
            print(line)


# ---- the run --------------------------------------------------------------------------

def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--one":
        one(argv[1:])
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("comparison", choices=("first", "resolve", "mpc", "nlp"))
    parser.add_argument("--repeat", type=int, help="rounds of first solves (default 15), "
                        "cycles of re-solves, solves per size of nlp (default 5)")
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES),
                        help="nlp: the N over which the exponent is fitted")
    parser.add_argument("--problem", choices=PROBLEMS, default="both")
    parser.add_argument("--rounds", type=int, default=3,
                        help="re-solves: child processes per method and checkout; the least time is kept")
    parser.add_argument("--goals", type=int, default=5, help="re-solves: goals near the original (<= 6)")
    parser.add_argument("--checkouts", nargs="+", default=[os.getcwd()],
                        help="dmoc checkouts to time (default: the current directory); first "
                        "solves of two or more: dmoc's alone, in child processes")
    parser.add_argument("--rockit-jit", action="store_true",
                        help="also rockit's function re-solve compiled to C (20-40 s per child)")
    parser.add_argument("--horizon", type=int, default=30, help="mpc: the controllers' horizon (steps)")
    parser.add_argument("--steps", type=int, default=40, help="mpc: closed-loop steps")
    parser.add_argument("--scan", action="store_true", help="find the least N within 1e-6 again")
    parser.add_argument("--smallest", action="store_true",
                        help="the rolling disk with lobatto4 only, once, in this process")
    args = parser.parse_args(argv)
    peers = {peer for peer, module in PEER_MODULES.items()
             if importlib.util.find_spec(module.split(".")[0])}
    for peer in sorted(peers):
        print(f"{peer} {importlib.metadata.version(PEER_DISTRIBUTIONS[peer])}", end="; ")
    if "rockit" not in peers:
        print("rockit is not importable here: the peer side is skipped (see the docstring "
              "for its environment)", end="; ")
    print(f"python {platform.python_version()}, casadi {ca.__version__}; {os.cpu_count()} cores; "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    names, rules = PROBLEMS[args.problem], DMOC_RULES
    if args.smallest:
        names, rules, args.rounds, args.goals, args.repeat = ("rolling disk",), ("lobatto4",), 1, 1, 1
        args.horizon, args.steps, args.sizes = 8, 4, [8, 16]
    if args.scan:
        n_star = scans(peers)
        print("least N with |J_N - J*| / J* <= 1e-6:", {f"{k[0]}, {k[1]}": v for k, v in n_star.items()})
    else:
        n_star = {(name, method): N for name, row in LEAST_N.items() for method, N in row.items()}
    if args.comparison == "mpc":
        mpcs(args, peers)
    elif args.comparison == "nlp":
        args.repeat = args.repeat or 5
        nlp_solves(names, n_star, args, peers)
    elif args.comparison == "first" and len(args.checkouts) > 1:
        checkout_firsts(names, args.checkouts, args.repeat or 5)
    elif args.comparison == "first":
        first_solves(names, rules, n_star, args.repeat or 15, peers)
    else:
        args.repeat = args.repeat or 5
        resolves(names, rules, n_star, args, peers)
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
