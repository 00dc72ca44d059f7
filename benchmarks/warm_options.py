"""Benchmark: dmoc's warm-start IPOPT options against IPOPT's own defaults for them, on
chains of warm re-solves with changed data and on the knife-edge MPC, in one process.

A warm re-solve runs IPOPT with `dmoc.optimal_control.solver.ipopt.WARM_START_OPTIONS`: besides
warm_start_init_point "yes", fast_step_computation "yes" (each KKT solution taken as MUMPS
returns it, its residual not computed); `--arm` adds options to dmoc's arm (e.g.
'{"mumps_scaling": 0}', an earlier warm option). Each problem is solved cold once; from that optimum two chains of warm re-solves
run in lockstep over the same changed data: "dmoc" with ``options=None`` (the warm
options) and "IPOPT" with ``options={"mumps_scaling": 77, "fast_step_computation": "no"}``
(IPOPT's defaults, given explicitly), each from its own last converged result, with
``throw=False``; the arm that goes first turns re-solve by re-solve. The data change by
`FRACTIONS` (1 %, 10 %, 50 %) of the motion: the goal's given entries (or the parameters,
by their scale) each move by that much with a random sign, the other way where a range that
keeps the problem feasible would be left, and clipped into it. `--repeat` chains per
problem (seeds 0, 1, ...). The "mpc" row is the closed loop of examples/mpc_knife_edge.py
(horizon 30, plant 10 % heavier, kick at step 10): two `dmoc.MPC` controllers, one per
option set, fed the same measured states (the plant driven by dmoc's controls), `--steps`
steps; its figures are over the warm steps (step 0 is a cold solve with IPOPT's defaults
in both). Per row: the re-solves ("n"),
iterations summed per arm and the number of re-solves where they differ, failures per arm;
where both converged, the largest relative difference of x (max |x_dmoc - x_IPOPT| /
max |x_IPOPT|) and of the cost, and the median ratio of IPOPT's time
(``stats["ipopt_time"]``), dmoc / IPOPT. The default run takes about 20 s, `--quick` 2 s.

    python benchmarks/warm_options.py [--repeat 1] [--steps 40] [--problems NAME ...] [--arm JSON] [--quick]
"""

import argparse
import json
import os
import sys

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
import dmoc.problems as P  # noqa: E402
from dmoc.optimal_control.solver.ipopt import WARM_START_OPTIONS  # noqa: E402
from dmoc.optimal_control.solver.solving import solve  # noqa: E402

EXAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples")
ARMS = {"IPOPT": {"mumps_scaling": 77, "fast_step_computation": "no"}, "dmoc": None}
FRACTIONS = (0.01, 0.1, 0.5, 0.01, 0.5, 0.1, 0.5, 0.01, 0.1, 0.5)
QUICK = {"problems": ("disk-lobatto4", "knife-bounds", "lc", "mpc"), "fractions": FRACTIONS[:4], "steps": 12}


def moved(value, step, low, high):
    """value + step, with each entry that would leave [low, high] moved by -step instead,
    then clipped into it."""
    ahead = value + step
    return np.clip(np.where((ahead < low) | (ahead > high), value - step, ahead), low, high)


def goal_change(directions, low=-np.inf, high=np.inf):
    """change(problem, fraction, rng): `problem` with its goal q `moved` by fraction *
    directions @ s, s of random signs (directions shape (n, k)); free entries stay free."""
    def change(problem, fraction, rng):
        step = fraction * np.asarray(directions) @ rng.choice((-1.0, 1.0), np.shape(directions)[1])
        goal = moved(problem.q_goal, step, low, high)
        return problem.with_boundary(q_goal=[None if np.isnan(g) else float(g) for g in goal])
    return change


def motion(problem):
    """Directions for `goal_change`, shape (n, n): each entry of the goal alone, by the size
    of the motion |q_goal - q_start| (its given entries)."""
    return np.eye(problem.disc.system.n) * np.linalg.norm(np.nan_to_num(problem.q_goal - problem.q_start))


def parameter_change(scale, low, high):
    """change(problem, fraction, rng): `problem` with each parameter entry `moved` by
    fraction * its `scale` with a random sign (dicts by name)."""
    def change(problem, fraction, rng):
        return problem.with_parameters(**{
            name: moved(value, fraction * scale[name] * rng.choice((-1.0, 1.0), value.shape),
                        low[name], high[name]) for name, value in problem.parameter_values.items()})
    return change


def knife_bounds():
    """Knife-edge parking, N = 50, |u| at most 0.7 of the unbounded optimum's largest; the
    goal kept in a box where some bounds are active at every optimum (4 to 38 at its
    corners) and the problem feasible (y = 1.5 is not; at (0.2, 1.2, 0.3), solved cold, a
    warm re-solve stopped at Infeasible_Problem_Detected in both arms)."""
    free = P.knife_edge_parking(50)
    bound = 0.7 * np.abs(solve(free).trajectory.u).max()
    problem = dmoc.OptimalControlProblem(free.disc, 50, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                         control_bounds=([-bound] * 2, [bound] * 2))
    return (f"knife midpoint N=50, |u| <= {bound:.3g}", problem, None,
            goal_change(motion(problem), low=[-0.2, 0.8, -0.3], high=[0.2, 1.1, 0.3]))


def knife_free_time():
    """Knife-edge parking, lobatto3, N = 20, the duration free in [0.5, 3] s."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    problem = dmoc.OptimalControlProblem(disc, 20, q_start=[0, 0, 0], q_goal=[0, 1, 0], duration=(0.5, 3.0))
    return "knife lobatto3 N=20, T in [0.5, 3]", problem, None, goal_change(motion(problem))


def sphere():
    """The spherical pendulum of tests/optimize/test_separable.py (its "free" goal),
    lobatto3, N = 30, 1 s; the goal's x and y move by 0.3 times the fraction."""
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(), 1.0 / 30, rule="lobatto3")
    problem = dmoc.OptimalControlProblem(disc, 30, q_start=[np.sin(0.5), 0.0, -np.cos(0.5)],
                                         q_goal=[0.0, np.sin(0.5), None], v_goal=[None, 0.1, None])
    return ("sphere (holonomic) lobatto3 N=30", problem, None,
            goal_change(np.diag([0.3, 0.3, 0.0]), low=-0.6, high=0.6))


def lc_circuit():
    """examples/lc_circuit.py's steering, N = 100: the charge's goal (split between the
    capacitors) moves by the fraction of the charge, kept in [0.25, 2] (at 0 the optimum is
    0 and relative differences say nothing)."""
    C1, C2 = 0.5, 1.5
    split = np.array([[1.0], [C1 / (C1 + C2)], [C2 / (C1 + C2)]])
    disc = dmoc.discretize(dmoc.systems.lc_circuit(0.8, (C1, C2)), 3.0 / 100)
    problem = dmoc.OptimalControlProblem(disc, 100, q_start=[0, 0, 0], q_goal=split[:, 0])
    return ("LC circuit (degenerate) midpoint N=100", problem, None,
            goal_change(split, low=0.25 * split[:, 0], high=2.0 * split[:, 0]))


def knife_parameters():
    """tests/optimize/test_parameters.py's knife edge, N = 30: the weight r of u_1^2 and an
    obstacle disc (centre c, radius rho) as parameters, moved by the fraction of (4, 0.2, 0.2)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=1.0), 0.1)
    problem = dmoc.OptimalControlProblem(
        disc, 30, q_start=[0, 0, 0], q_goal=[0, 1, 0], parameters={"r": 4.0, "c": [-0.1, 0.5], "rho": 0.2},
        running_cost=lambda q, v, u, w: u[0] ** 2 + w["r"] * u[1] ** 2,
        path_constraints=lambda q, v, u, w: w["rho"] ** 2 - ca.sumsqr(q[:2] - w["c"]))
    change = parameter_change({"r": 4.0, "c": 0.2, "rho": 0.2}, {"r": 0.25, "c": [-0.3, 0.4], "rho": 0.1},
                              {"r": 16.0, "c": [0.3, 0.6], "rho": 0.3})
    return "knife N=30, parameters r, c, rho", problem, None, change


def lane_change():
    """examples/lane_change_problem.py, N = 60: the goal lane's y moves by the fraction of
    the lane width, kept in [2.5, 5] m."""
    sys.path.insert(0, EXAMPLES)
    from lane_change_problem import LANE, lane_change as example
    problem = example(60)
    return ("lane change (example) N=60", problem, None,
            goal_change(np.diag([0.0, LANE, 0.0, 0.0]), low=[-np.inf, 2.5, -1, -1], high=[np.inf, 5.0, 1, 1]))


def car():
    """`dmoc.problems.car_lane_change` (SI, 1500 kg), midpoint N = 60, from the uniform
    motion; the goal's x and y move by the fraction of (40 m, 3.5 m)."""
    problem = P.car_lane_change()
    return ("car lane change midpoint N=60", problem, P.uniform_motion_guess(problem),
            goal_change(np.diag([40.0, 3.5, 0.0, 0.0])))


def parking(name, make):
    """A builder of the problem `make()` of `dmoc.problems`, its goal moved by the fraction of
    the motion."""
    def build():
        problem = make()
        return name, problem, None, goal_change(motion(problem))
    return build


PROBLEMS = {"disk-lobatto4": parking("disk lobatto4 N=11",
                                     lambda: P.rolling_disk_steering(11, rule="lobatto4")),
            "disk-midpoint": parking("disk midpoint N=100", lambda: P.rolling_disk_steering(100)),
            "knife": parking("knife lobatto3 N=28", lambda: P.knife_edge_parking(28, rule="lobatto3")),
            "car": car, "knife-bounds": knife_bounds, "knife-free-time": knife_free_time,
            "sphere": sphere, "lc": lc_circuit, "knife-parameters": knife_parameters,
            "lane-change": lane_change}


def outcome(result):
    """{success, iterations, seconds in IPOPT, x, cost} of an OptimizationResult."""
    return {"success": bool(result.success), "iterations": int(result.stats["iterations"]),
            "seconds": result.stats["ipopt_time"], "x": result.x, "cost": result.cost}


def chains(build, repeat, fractions):
    """[(outcome IPOPT, outcome dmoc)] of `repeat` lockstep chains of warm re-solves over
    the changes of `build`'s problem by `fractions`, all from one cold solve."""
    label, problem, guess, change = build()
    cold = solve(problem, guess=guess, throw=False)
    pairs, turn = [], 0
    for seed in range(repeat):
        rng, data, previous = np.random.default_rng(seed), problem, dict.fromkeys(ARMS, cold)
        for fraction in fractions:
            data, results = change(data, fraction, rng), {}
            for arm in list(ARMS)[turn % 2:] + list(ARMS)[:turn % 2]:
                results[arm] = solve(data, guess=previous[arm], options=ARMS[arm], throw=False)
                previous[arm] = results[arm] if results[arm].success else previous[arm]
            pairs.append(tuple(outcome(results[arm]) for arm in ARMS))
            turn += 1
    return label, pairs


def mpc(steps):
    """("mpc ...", [(outcome IPOPT, outcome dmoc)]) of the warm steps of two `dmoc.MPC`
    controllers of examples/mpc_knife_edge.py's closed loop, fed the same states."""
    sys.path.insert(0, EXAMPLES)
    from mpc_knife_edge import KICK, KICK_STEP
    problem = P.knife_edge_parking(30, duration=3.0)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1, inertia=1.0), problem.disc.h)
    controllers = {arm: dmoc.MPC(problem, options=options, on_failure="shift")
                   for arm, options in ARMS.items()}
    q, p, pairs = np.zeros(3), np.zeros(3), []
    for k in range(steps):
        u = {arm: controllers[arm].step(q, p=p) for arm in list(ARMS)[k % 2:] + list(ARMS)[:k % 2]}
        if k > 0:
            pairs.append(tuple(outcome(c.plan) if c.log[-1].success else
                               {"success": False, "iterations": c.log[-1].iterations}
                               for c in controllers.values()))
        if k == KICK_STEP:
            p = p + KICK * np.array([np.cos(q[2]), np.sin(q[2]), 1.0])
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u["dmoc"][None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
    return f"mpc knife N=30, {steps} steps (warm)", pairs


def row(label, pairs):
    """One line of the table from [(outcome IPOPT, outcome dmoc)]."""
    both = [(a, b) for a, b in pairs if a["success"] and b["success"]]
    dx = max((np.abs(b["x"] - a["x"]).max() / np.abs(a["x"]).max() for a, b in both), default=np.nan)
    dJ = max((abs(b["cost"] - a["cost"]) / abs(a["cost"]) for a, b in both), default=np.nan)
    ratio = np.median([b["seconds"] / a["seconds"] for a, b in both]) if both else np.nan
    it = [sum(pair[i]["iterations"] for pair in pairs) for i in (0, 1)]
    differ = sum(a["iterations"] != b["iterations"] for a, b in pairs)
    fails = [sum(not pair[i]["success"] for pair in pairs) for i in (0, 1)]
    return (f"{label:<38}{len(pairs):>4}{it[0]:>10}{it[1]:>9}{differ:>8}{fails[0]:>12}{fails[1]:>11}"
            f"{dx:>10.1e}{dJ:>10.1e}{ratio:>14.3f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=1, help="chains per problem (default 1)")
    parser.add_argument("--steps", type=int, default=40, help="MPC closed-loop steps (default 40)")
    parser.add_argument("--problems", nargs="+", choices=[*PROBLEMS, "mpc"], default=[*PROBLEMS, "mpc"],
                        metavar="NAME", help=f"of {', '.join([*PROBLEMS, 'mpc'])} (default all)")
    parser.add_argument("--arm", type=json.loads, default=None, metavar="JSON",
                        help="IPOPT options added to dmoc's arm, e.g. '{\"mumps_scaling\": 0}'")
    parser.add_argument("--quick", action="store_true",
                        help=f"{', '.join(QUICK['problems'])}; {len(QUICK['fractions'])} re-solves, "
                             f"{QUICK['steps']} MPC steps")
    args = parser.parse_args(argv)
    ARMS["dmoc"] = args.arm
    names, fractions, steps = ((QUICK["problems"], QUICK["fractions"], QUICK["steps"]) if args.quick
                               else (args.problems, FRACTIONS, args.steps))
    print(f"warm options: dmoc {WARM_START_OPTIONS} (with {args.arm}) against IPOPT {ARMS['IPOPT']}; "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    print(f"\n{'problem':<38}{'n':>4}{'it IPOPT':>10}{'it dmoc':>9}{'differ':>8}{'fail IPOPT':>12}"
          f"{'fail dmoc':>11}{'max dx':>10}{'max dJ/J':>10}{'t dmoc/IPOPT':>14}")
    for name in names:
        pairs = mpc(steps) if name == "mpc" else chains(PROBLEMS[name], args.repeat, fractions)
        print(row(*pairs), flush=True)
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
