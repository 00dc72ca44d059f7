"""Benchmark: the fourth pass over a warm raw re-solve (issue 25; docs/performance.md,
"The re-solve, fourth pass"), in one process, before and after alternating call by call.

On rolling-disk steering (lobatto4, N = 11) and knife-edge parking (lobatto3, N = 28), two
chains of warm raw re-solves ``solve(problem.with_boundary(q_goal=g), guess=previous,
jit=True)`` over the goals of `resolve_outside.py` in a cycle: one with IPOPT's
``fixed_variable_treatment`` "make_parameter" given (before: IPOPT computes the fixed
variables' bound multipliers at every iteration, a gradient each) and one with dmoc's
default "make_parameter_nodual" (after: made on first access of result.lam_x), the two
called in turn (which goes first alternating); medians per re-solve of the wall time,
IPOPT's (``stats["ipopt_time"]``) and the difference. Every pair has the same bits (x,
lam_x, lam_g, cost, iterations), asserted after the timing. Then two pieces in their
former form (written out below) and their new one, hot, alternating: the solver's options
and cache key, and the SIGINT watch. With `--loop`, instead, where the time outside IPOPT
goes inside a loop of warm raw re-solves of the disk: each piece of `solve` (and
`with_boundary`) wrapped in a timer, medians per re-solve (the timers add their own
microsecond each).

    python benchmarks/resolve_lean.py [--count 600] [--calls 20000]
    python benchmarks/resolve_lean.py --loop 1000
"""

import argparse
import contextlib
import functools
import importlib
import os
import signal
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.optimal_control.solver import interrupt, ipopt  # noqa: E402
from dmoc.optimal_control.solver.solving import solve  # noqa: E402
from resolve_outside import CASES, OFFSETS, warm_resolves  # noqa: E402

BEFORE = {"fixed_variable_treatment": "make_parameter"}


def chains(name, count):
    """{"wall", "ipopt": ([before], [after])} seconds per re-solve of the two chains."""
    make, goal, q_goal = CASES[name]
    problem = make()
    options = (BEFORE, {})
    previous = [solve(problem.with_boundary(q_goal=q_goal(goal)), jit=True, options=o) for o in options]
    wall, ipopt_time = ([], []), ([], [])
    for i in range(30 + count):
        data = q_goal(goal + OFFSETS[i % len(OFFSETS)])
        for k in ((0, 1) if i % 2 else (1, 0)):
            tic = time.perf_counter()
            result = solve(problem.with_boundary(q_goal=data), guess=previous[k], jit=True, options=options[k])
            seconds = time.perf_counter() - tic
            previous[k] = result
            if i >= 30:
                wall[k].append(seconds)
                ipopt_time[k].append(result.stats["ipopt_time"])
    a, b = previous                     # read after the timing: the after chain's lam_x is made here
    for field in ("x", "lam_x", "lam_g"):
        assert np.array_equal(getattr(a, field).view(np.int64), getattr(b, field).view(np.int64)), field
    assert a.cost == b.cost and a.stats["iterations"] == b.stats["iterations"]
    return {"wall": wall, "ipopt": ipopt_time}


def former_options(options, report):
    """The solver's nlpsol options and cache key as made at every solve before."""
    merged = {**ipopt.DEFAULT_IPOPT_OPTIONS, **options}
    if report:
        merged["file_print_level"] = ipopt.JOURNAL_LEVEL
    opts = {"print_time": False, "error_on_fail": False, "no_nlp_grad": True, "calc_lam_p": False,
            "record_time": True, **{"ipopt." + k: v for k, v in merged.items()}}
    return merged, opts, repr(sorted(opts.items()))


@contextlib.contextmanager
def former_watch():
    """`interrupt.watch` before: through `signal`'s wrappers."""
    seen, previous = [], signal.getsignal(signal.SIGINT)

    def noted(signum, frame):
        seen.append(signum)
        previous(signum, frame)

    signal.signal(signal.SIGINT, noted)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, previous)


def pieces(calls):
    """{piece: (before, after)} median seconds, alternating."""
    options = dict(ipopt.start_options(True))

    def watched(watch):
        with watch():
            pass

    pairs = {"options and key of the solver": (
                 lambda: former_options(dict(options), False)[2],
                 lambda: ipopt._OPTION_SETS.get(
                     (tuple(ipopt.DEFAULT_IPOPT_OPTIONS.items()),
                      tuple((k, repr(v)) for k, v in dict(options).items()), False),
                     lambda: ipopt._nlpsol_options(options, False))[2]),
             "SIGINT watch": (lambda: watched(former_watch), lambda: watched(interrupt.watch))}
    out = {}
    for label, (old, new) in pairs.items():
        assert old() == new()
        times = ([], [])
        for _ in range(calls):
            for k, f in enumerate((old, new)):
                tic = time.perf_counter()
                f()
                times[k].append(time.perf_counter() - tic)
        out[label] = tuple(float(np.median(t)) for t in times)
    return out


def loop_pieces(count):
    """{piece: median seconds per re-solve} of `count` warm raw re-solves of the disk (after
    30 uncounted), each piece of `solve` timed where `solve` calls it; "outside" is the
    re-solve's wall time less IPOPT's."""
    module = importlib.import_module("dmoc.optimal_control.solver.solving")
    spent = {}

    def timed(label, function):
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            tic = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                spent.setdefault(label, []).append(time.perf_counter() - tic)
        return wrapper

    original = interrupt.watch

    @contextlib.contextmanager
    def watch():
        tic = time.perf_counter()
        with original() as seen:
            entered = time.perf_counter()
            yield seen
            left = time.perf_counter()
        spent.setdefault("SIGINT watch (enter and exit)", []).append(time.perf_counter() - left + entered - tic)

    wrapped = {"start_point": "start point", "data_tolerances": "data's tolerances",
               "ipopt_solver": "solver lookup", "_values_at_x": "f and g at x",
               "most_violated": "most violated row", "linear_algebra": "linear_algebra(stats)"}
    patches = [(module, name, timed(label, getattr(module, name))) for name, label in wrapped.items()]
    patches += [(module.interrupt, "watch", watch),
                (ipopt.PackedSolver, "__call__", timed("packed call less IPOPT", ipopt.PackedSolver.__call__)),
                (ipopt.PackedSolver, "stats", timed("IPOPT's stats()", ipopt.PackedSolver.stats)),
                (dmoc.OptimalControlProblem, "with_boundary",
                 timed("with_boundary", dmoc.OptimalControlProblem.with_boundary))]
    saved = [(owner, name, vars(owner)[name]) for owner, name, _ in patches]
    for owner, name, value in patches:
        setattr(owner, name, value)
    try:
        chain = list(warm_resolves("rolling disk, lobatto4, N = 11", 30 + count))[30:]
    finally:
        for owner, name, value in saved:
            setattr(owner, name, value)
    ipopt_time = np.array([result.stats["ipopt_time"] for _, result in chain])
    spent = {label: np.array(times[-count:]) for label, times in spent.items()}
    spent["packed call less IPOPT"] = spent["packed call less IPOPT"] - ipopt_time
    wall = np.array([seconds for seconds, _ in chain])
    return {"re-solve": float(np.median(wall)), "IPOPT": float(np.median(ipopt_time)),
            "outside": float(np.median(wall - ipopt_time)),
            **{label: float(np.median(times)) for label, times in spent.items()}}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=600, help="re-solves per chain and problem")
    parser.add_argument("--calls", type=int, default=20000, help="calls per piece")
    parser.add_argument("--loop", type=int, default=0, help="only time the pieces in this many re-solves")
    args = parser.parse_args(argv)
    print(f"dmoc from {dmoc.__file__}; load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start\n")
    if args.loop:
        print("| rolling disk, lobatto4, N = 11: in the loop | us per re-solve |\n|---|---:|")
        for label, seconds in loop_pieces(args.loop).items():
            print(f"| {label} | {1e6 * seconds:.1f} |")
        print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")
        return
    print("| problem | fixed variables' multipliers | ms | IPOPT ms | outside ms | ms / before | IPOPT / before |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name in ("rolling disk, lobatto4, N = 11", "knife edge, lobatto3, N = 28"):
        times = chains(name, args.count)
        med = {key: [float(np.median(t)) for t in times[key]] for key in times}
        outside = [float(np.median(np.subtract(w, i))) for w, i in zip(times["wall"], times["ipopt"])]
        for k, label in enumerate(("by IPOPT (make_parameter)", "on first read (nodual)")):
            print(f"| {name if k == 0 else ''} | {label} | {1e3 * med['wall'][k]:.3f} | "
                  f"{1e3 * med['ipopt'][k]:.3f} | {1e3 * outside[k]:.3f} | "
                  f"{med['wall'][k] / med['wall'][0]:.3f} | {med['ipopt'][k] / med['ipopt'][0]:.3f} |")
    print("\n| piece (hot) | before us | after us | after / before |\n|---|---:|---:|---:|")
    for label, (old, new) in pieces(args.calls).items():
        print(f"| {label} | {1e6 * old:.1f} | {1e6 * new:.1f} | {new / old:.3f} |")
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
