"""Benchmark: the Python of a raw re-solve outside IPOPT, third pass of issue 25 (the
result's trajectory made on first access; the data's row sums of one stacked [x0; p]; the
velocity rows found once per problem; q_ref without ``nan_to_num``), against the code
before, interleaved call by call in one process.

On rolling-disk steering (lobatto4, N = 11) and knife-edge parking (lobatto3, N = 28;
lobatto4, N = 14), the N of the rockit comparison (docs/performance.md), each changed piece
is timed in its new form and in its former one (written out below), then the whole raw
re-solve ``solve(problem.with_boundary(q_goal=g), guess=previous, jit=True)`` over the
goals of `peers_resolve.py` in a cycle, with the former pieces swapped in ("before": the
former row sums and q_ref, the trajectory made at once) and without ("after"): medians
over `--calls` alternating calls, and of the re-solves also the median time outside
IPOPT (the call's time less ``stats["solve_time"]``). Every pair is checked to give the
same bits (x, multipliers, cost, iterations and, once made, the trajectory). Last, IPOPT's
time in two chains of warm re-solves, with MUMPS's scaling of the KKT matrices (before)
and without (after; dmoc's warm option from the third to the eighth pass): the same
iterations.

    python benchmarks/resolve_outside.py [--calls 1000]
    perf record -D 4000 -F 1500 --call-graph dwarf,32768 python benchmarks/resolve_outside.py --loop 1500
"""

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
import dmoc.problems  # noqa: E402
from dmoc._util.conversions import column  # noqa: E402
from dmoc._util.deferred import Pending  # noqa: E402
from dmoc.optimal_control.solver import ipopt, solving as solve_module  # noqa: E402
from dmoc.optimal_control.nlp import transcription as transcription_module
from dmoc.optimal_control.nlp.evaluation import nlp_functions  # noqa: E402
from dmoc.optimal_control.solver.guess import start_point  # noqa: E402
from dmoc.optimal_control.solver.solving import solve, trajectory_from_x  # noqa: E402

OFFSETS = np.array([[0.05, 0.0, 0.0], [0.0, 0.05, 0.05], [-0.05, 0.05, 0.0],
                    [0.05, -0.05, -0.05], [0.0, 0.1, 0.1], [0.0, 0.0, 0.0]])
CASES = {   # (problem, goal (x, y, heading), q_goal of a goal)
    "rolling disk, lobatto4, N = 11": (
        lambda: dmoc.problems.rolling_disk_steering(11, rule="lobatto4", duration=4.0),
        np.array([1.0, 1.0, np.pi / 2]), lambda g: [g[0], g[1], None, g[2]]),
    "knife edge, lobatto3, N = 28": (
        lambda: dmoc.problems.knife_edge_parking(28, rule="lobatto3", duration=4.0),
        np.array([0.0, 1.0, 0.0]), list),
    "knife edge, lobatto4, N = 14": (
        lambda: dmoc.problems.knife_edge_parking(14, rule="lobatto4", duration=4.0),
        np.array([0.0, 1.0, 0.0]), list),
}
FIELDS = ("t", "q", "p", "lam", "u", "h", "mu", "s")
_FORMER = {}


def former_data_tolerances(T, x0, jit=False):
    """`data_tolerances` before: the row sums of [x0; x_abs; p], x_abs formed in NumPy."""
    def build():
        sep = T.separable
        z = ca.MX.sym("z", 2 * sep.n_x + sep.n_p)
        x, x_abs, p = z[:sep.n_x], z[sep.n_x:2 * sep.n_x], z[2 * sep.n_x:]
        jacobian = nlp_functions(sep, jit=jit)["nlp_jac_g"](x, p)[1]
        return ca.Function("former", [z], [ca.mmax(ca.mtimes(ca.fabs(jacobian), ca.fabs(x_abs)))])
    key = (T.structure, jit)
    largest = _FORMER[key] = _FORMER.get(key) or build()
    x = np.array(x0, dtype=float)
    x[T.x_layout.slice("q")] = T.configurations(x0).ravel()
    floor = np.finfo(float).eps * float(largest(column(np.concatenate([x0, x, T.p]))))
    if not floor > ipopt.DEFAULT_IPOPT_OPTIONS["constr_viol_tol"]:
        return {}
    floor = float(2.0 ** np.ceil(np.log2(floor)))
    return {"tol": floor, "constr_viol_tol": floor}


def former_reference(q_start, q_goal):
    """`transcription.reference` before."""
    return np.where(np.isfinite(q_start), q_start, np.nan_to_num(q_goal, nan=0.0))


def former_imposes_velocity_rows(q, v):
    """`boundary.imposes_velocity_rows(q, v)` before the ninth pass (which takes whether q
    and v are fully given instead of q)."""
    return not ((np.isfinite(q).all() and np.isfinite(v).all()) or (np.isfinite(v).all() and not v.any()))


def former_velocity_rows(problem):
    """`problem.velocity_rows` before: found at every read (twice per `with_boundary`)."""
    return {"start": problem.p_start is None and former_imposes_velocity_rows(problem.q_start, problem.v_start),
            "goal": former_imposes_velocity_rows(problem.q_goal, problem.v_goal)}


def alternate(pair, calls, check=True):
    """[median seconds] of `calls` alternating calls of the two functions in `pair`; with
    `check`, their outputs of the first round have the same bits (`same`); without, a
    function that returns a float returns its own time."""
    (old, new), times = pair, ([], [])
    for i in range(calls):
        outs = []
        for k, f in enumerate((old, new)):
            tic = time.perf_counter()
            outs.append(f())
            times[k].append(outs[-1] if isinstance(outs[-1], float) else time.perf_counter() - tic)
        if i == 0 and check:
            same(*outs)
    return [float(np.median(t)) for t in times]


def same(a, b):
    """Assert the same bits: floats, arrays, dicts, results (their trajectories made)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            same(a[key], b[key])
    elif hasattr(a, "lam_g"):
        for name in ("x", "lam_x", "lam_g", "cost"):
            same(getattr(a, name), getattr(b, name))
        assert a.stats["iterations"] == b.stats["iterations"]
        for name in FIELDS:
            same(getattr(a.trajectory, name), getattr(b.trajectory, name))
    elif isinstance(a, (bool, str)):
        assert a == b
    else:
        assert np.array_equal(np.asarray(a, dtype=float).view(np.int64),
                              np.asarray(b, dtype=float).view(np.int64)), (a, b)


class Former:
    """Within the block, `solve` uses the former row sums and `Transcription` the former
    q_ref."""

    def __enter__(self):
        solve_module.data_tolerances = former_data_tolerances
        transcription_module.reference = former_reference

    def __exit__(self, *exc):
        solve_module.data_tolerances = ipopt.data_tolerances
        transcription_module.reference = NEW_REFERENCE


NEW_REFERENCE = transcription_module.reference


def case(name, make, goal, q_goal, calls):
    problem = make()
    previous = solve(problem.with_boundary(q_goal=q_goal(goal)), jit=True)
    new = problem.with_boundary(q_goal=q_goal(goal + OFFSETS[0]))
    T = new.transcription
    x0 = start_point(new, previous)[0] / T.x_scale
    x = previous.x
    pieces = {
        "data tolerances (row sums)": (lambda: former_data_tolerances(T, x0, True),
                                       lambda: ipopt.data_tolerances(T, x0, True)),
        "q_ref": (lambda: former_reference(new.q_start, new.q_goal),
                  lambda: transcription_module.reference(new.q_start, new.q_goal)),
        "velocity rows (with_boundary's test)": (
            lambda: former_velocity_rows(new) == former_velocity_rows(problem),
            lambda: new._velocity_rows == problem._velocity_rows),
        # made at once against deferred (the x copied): not the same value, not checked
        "the result's trajectory (made / deferred)": (lambda: trajectory_from_x(new, x),
                                                      lambda: Pending(trajectory_from_x, new, x.copy())),
    }
    print(f"\n{name}: x {T.x_layout.size}, g {T.g_layout.size}")
    print(f"{'piece':44s} {'before us':>10s} {'after us':>9s} {'after/before':>13s}")
    for label, pair in pieces.items():
        before, after = alternate(pair, calls, check="trajectory" not in label)
        print(f"{label:44s} {1e6 * before:10.1f} {1e6 * after:9.1f} {after / before:13.3f}")
    state = {"i": 0, "previous": [previous, previous], "outside": ([], [])}

    def resolve(k):
        def run():
            moved_goal = q_goal(goal + OFFSETS[state["i"] % len(OFFSETS)])
            tic = time.perf_counter()
            if k == 0:
                with Former():
                    result = solve(problem.with_boundary(q_goal=moved_goal), guess=state["previous"][k], jit=True)
                    result.trajectory           # made at once, as before
            else:
                result = solve(problem.with_boundary(q_goal=moved_goal), guess=state["previous"][k], jit=True)
            state["outside"][k].append(time.perf_counter() - tic - result.stats["solve_time"])
            state["previous"][k] = result
            state["i"] += k
            return result
        return run
    rounds = max(calls // 4, 60)
    before, after = alternate((resolve(0), resolve(1)), rounds)
    outside = [float(np.median(t)) for t in state["outside"]]
    print(f"{'raw re-solve, jit=True (IPOPT included)':44s} {1e6 * before:10.1f} {1e6 * after:9.1f} "
          f"{after / before:13.3f}")
    print(f"{'  of it outside IPOPT':44s} {1e6 * outside[0]:10.1f} {1e6 * outside[1]:9.1f} "
          f"{outside[1] / outside[0]:13.3f}")
    same(*state["previous"])                   # the two chains stayed the same, bit for bit
    scaled = alternate(warm_chains(problem, goal, q_goal, previous), rounds, check=False)
    print(f"{'IPOPT time of a warm re-solve, MUMPS scaling':44s} {1e6 * scaled[0]:10.1f} "
          f"{1e6 * scaled[1]:9.1f} {scaled[1] / scaled[0]:13.3f}")


def warm_chains(problem, goal, q_goal, previous):
    """Two chains of raw re-solves over the goals, the first with MUMPS's scaling of the
    KKT matrices as before (``mumps_scaling`` 77, MUMPS's default), the second without (0,
    dmoc's warm option from the third to the eighth pass): each returns IPOPT's time (``stats["solve_time"]``); the same
    iterations are asserted, and the optima agree to 1e-12 (not bit for bit: the pivots'
    scaling differs)."""
    state = {"i": 0, "previous": [previous, previous]}

    def chain(k):
        def run():
            moved = problem.with_boundary(q_goal=q_goal(goal + OFFSETS[state["i"] % len(OFFSETS)]))
            options = {"mumps_scaling": 77 if k == 0 else 0}
            result = solve(moved, guess=state["previous"][k], jit=True, options=options)
            state["previous"][k] = result
            if k == 1:
                state["i"] += 1
                a, b = state["previous"]
                assert a.stats["iterations"] == b.stats["iterations"]
                assert np.max(np.abs(a.x - b.x)) <= 1e-12 * max(1.0, np.max(np.abs(a.x)))
            return result.stats["solve_time"]
        return run
    return chain(0), chain(1)


def warm_resolves(name, total):
    """Yield (wall seconds, result) of `total` warm raw re-solves ``solve(problem.
    with_boundary(q_goal=g), guess=previous, jit=True)`` of case `name`, the goals of
    OFFSETS in a cycle, each from the previous optimum (the wall time with `with_boundary`)."""
    make, goal, q_goal = CASES[name]
    problem = make()
    previous = solve(problem.with_boundary(q_goal=q_goal(goal)), jit=True)
    for i in range(total):
        tic = time.perf_counter()
        previous = solve(problem.with_boundary(q_goal=q_goal(goal + OFFSETS[i % len(OFFSETS)])),
                         guess=previous, jit=True)
        yield time.perf_counter() - tic, previous


def loop(count):
    """`count` warm raw re-solves of the rolling disk (the first case, jit=True), the goals
    in a cycle, after 50 uncounted: a steady loop to sample with ``perf record`` or
    cProfile. Prints the median wall time and IPOPT's (``solve_time``) per re-solve."""
    chain = list(warm_resolves("rolling disk, lobatto4, N = 11", 50 + count))[50:]
    wall = [seconds for seconds, _ in chain]
    ipopt_time = [result.stats["solve_time"] for _, result in chain]
    print(f"{count} raw re-solves: median {1e3 * np.median(wall):.3f} ms, of it IPOPT "
          f"{1e3 * np.median(ipopt_time):.3f} ms")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=1000)
    parser.add_argument("--loop", type=int, default=0,
                        help="only run this many raw re-solves of the disk (for perf or cProfile)")
    args = parser.parse_args(argv)
    if args.loop:
        loop(args.loop)
        return
    print(f"dmoc from {dmoc.__file__}; load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    for name, (make, goal, q_goal) in CASES.items():
        case(name, make, goal, q_goal, args.calls)
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
