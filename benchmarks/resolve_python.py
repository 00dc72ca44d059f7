"""Benchmark: the Python of a raw re-solve outside IPOPT, the conversions of issue 25's
second pass (NumPy to DM and back through lists, `dmoc._util.conversions`; the
substituted momenta gathered by index arrays made once; the result's Trajectory assembled
without re-checking) against the code before them, interleaved call by call in one
process.

On rolling-disk steering (lobatto4, N = 11) and knife-edge parking (lobatto3, N = 28; and
the MPC's horizon, midpoint, N = 30, from a start momentum), the N of the rockit
comparison (docs/performance.md), the pieces that changed are timed in their new form and
in their old one (written out below: CasADi's own conversion of the NumPy arrays, and the
momenta's windows gathered one by one): the packed IPOPT call (`PackedSolver.__call__`,
IPOPT included), the data's row sums (`data_tolerances`), the result's momenta
(`Transcription.momenta`) and its trajectory (`trajectory_from_x`); then the whole raw
re-solve ``solve(problem.with_boundary(
q_goal=g), guess=previous, jit=True)`` with the old and the new pieces swapped in. Every
pair is checked to give the same bits. Reported: medians over `--calls` alternating calls
(microseconds) and new / old.

"New" is today's code: the packed IPOPT call and the row sums have gone through their
Functions' buffers (`dmoc._util.numeric.Evaluator`) since the third pass, not through
the lists of the second, so their rows compare CasADi's own conversions with the buffers
(the old forms call the Function the Evaluator wraps, ``Evaluator.function``).

    python benchmarks/resolve_python.py [--calls 2000]
"""

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import dmoc  # noqa: E402
import dmoc.problems  # noqa: E402
from dmoc.optimal_control.solver import ipopt  # noqa: E402
from dmoc.optimal_control.nlp import momenta as momenta_module
from dmoc.optimal_control.solver.guess import start_point  # noqa: E402
from dmoc.optimal_control.solver import solving as solve_module  # noqa: E402
from dmoc.optimal_control.solver.solving import solve, trajectory_from_x  # noqa: E402
from dmoc.principle.trajectory import Trajectory  # noqa: E402
from dmoc.optimal_control.nlp.terms import broadcast  # noqa: E402

CASES = {
    "rolling disk, lobatto4, N = 11": (
        lambda: dmoc.problems.rolling_disk_steering(11, rule="lobatto4"),
        ([1.05, 1.0, None, 1.6], [1.0, 1.05, None, 1.55])),
    "knife edge, lobatto3, N = 28": (
        lambda: dmoc.problems.knife_edge_parking(28, rule="lobatto3"),
        ([0.05, 1.0, 0.0], [0.0, 1.05, 0.05])),
    "knife edge MPC, midpoint, N = 30": (
        lambda: dmoc.problems.knife_edge_parking(30, duration=3.0).with_boundary(p_start=[0.0] * 3),
        ([0.05, 1.0, 0.0], [0.0, 1.05, 0.05])),
}


def old_packed_call(self, **inputs):
    """`PackedSolver.__call__` before: the packed Function called on the NumPy input, the
    output by `full()`."""
    z = np.concatenate([inputs[name] for name in self._inputs.blocks])
    return self._outputs.split(self._function.function(z).full().ravel())


def old_stats(self):
    """`PackedSolver.stats` before: those of the packed Function's own last call."""
    return self._function.function.stats()


def old_row_sums(T, x0, jit):
    """`data_tolerances`' row sums before: CasADi converts the NumPy vector (of [x0; p],
    the argument since the third pass, benchmarks/resolve_outside.py)."""
    largest = ipopt._ROW_SUMS.get((T.structure, jit), None)
    return float(largest.function(np.concatenate([x0, T.p])))


def new_row_sums(T, x0, jit):
    """`data_tolerances`' row sums now: through the Function's buffer."""
    largest = ipopt._ROW_SUMS.get((T.structure, jit), None)
    return float(largest(np.concatenate([x0, T.p]))[0][0, 0])


def old_momenta(problem):
    """`Transcription.momenta` before: p1's windows gathered one by one, CasADi's own
    conversions."""
    from dmoc.optimal_control.nlp.terms import _StepSlots, _indices
    T, N = problem.transcription, problem.steps
    X, P, G = (_indices(lay) for lay in (T.x_layout, T.p_layout, T.g_layout))
    slots = _StepSlots(problem, X, P, G, (T.x_scale, T.g_scale), (T.x_layout.size, T.p_layout.size))
    treatment = problem.momentum_treatment
    windows = [slots.at(0, N, "_prev")[k if k == "h" else k + "_prev"] for k in treatment.p1.name_in()]
    mapped = momenta_module._MOMENTA.get((treatment.residual.key, N), None)

    def momenta(x, p):
        source = {"x": x, "q": x, "p": p}
        stacked = np.vstack([source[src][broadcast(index, N)] + (p[slots.q_ref] if src == "q" else 0)
                             for src, index in windows])
        return np.hstack([x[X["p"][:, :1]], mapped(stacked).full()]).T
    return momenta


def old_trajectory(problem, x, momenta):
    """`trajectory_from_x` before: the checking constructor, `momenta` the old momenta."""
    T, N = problem.transcription, problem.steps
    lay = T.x_layout
    h = problem.final_time.step(lay, x)
    mu = lay.unpack(x, "mu")[:, 0] if lay.numel("mu") else np.zeros(problem.disc.system.m)
    return Trajectory(h * np.arange(N + 1), T.configurations(x), momenta(x, T.p),
                      lay.unpack(x, "lam").T, lay.unpack(x, "u").T, h, problem.formulation.name,
                      mu, lay.unpack(x, "s").T, problem.disc.rule.control_nodes,
                      problem.disc.rule.stage_nodes)


def alternate(old, new, calls):
    """(median old, median new) seconds of `calls` alternating calls; their results
    checked to be the same bits."""
    times = ([], [])
    for i in range(calls):
        for k, f in enumerate((old, new)):
            tic = time.perf_counter()
            out = f()
            times[k].append(time.perf_counter() - tic)
            if i == 0:
                if k == 0:
                    first = out
                else:
                    same(first, out)
    return np.median(times[0]), np.median(times[1])


def same(a, b):
    """Assert that two results (arrays, floats, dicts of arrays, results) have the same bits."""
    if isinstance(a, dict):
        for key in a:
            same(a[key], b[key])
    elif hasattr(a, "x") and hasattr(a, "lam_g"):
        for field in ("x", "lam_x", "lam_g", "cost"):
            same(getattr(a, field), getattr(b, field))
        same(a.trajectory, b.trajectory)
    elif isinstance(a, Trajectory):
        for field in ("t", "q", "p", "lam", "u", "h", "mu", "s"):
            same(getattr(a, field), getattr(b, field))
        assert (a.variant, a.control_nodes, a.stage_nodes) == (b.variant, b.control_nodes, b.stage_nodes)
    else:
        assert np.array_equal(np.asarray(a, dtype=float).view(np.int64),
                              np.asarray(b, dtype=float).view(np.int64)), (a, b)


def swapped(old):
    """Install the old (True) or the new (False) packed call and its statistics."""
    ipopt.PackedSolver.__call__ = old_packed_call if old else NEW_PACKED_CALL
    ipopt.PackedSolver.stats = old_stats if old else NEW_STATS


NEW_PACKED_CALL, NEW_STATS = ipopt.PackedSolver.__call__, ipopt.PackedSolver.stats


def case(name, make, goals, calls):
    problem = make()
    previous = solve(problem, jit=True)
    moved = [problem.with_boundary(q_goal=g) for g in goals]
    new = moved[0]
    T = new.transcription
    x0, lam_x0, lam_g0 = start_point(new, previous)
    D, R = T.x_scale, T.g_scale
    packed = ipopt.solver(T, {"warm_start_init_point": "yes"}, expand=False, reuse=True, report=False,
                          jit=True)[0]
    inputs = dict(x0=x0 / D, p=T.p, lam_x0=lam_x0 * D, lam_g0=lam_g0 / R, lbx=T.lbx / D,
                  ubx=T.ubx / D, lbg=T.lbg * R, ubg=T.ubg * R)
    x = previous.x
    trajectory_from_x(new, x)        # builds the mapped momenta (a result's trajectory is made on access)
    old_p = old_momenta(new)
    rows = {
        "packed IPOPT call": (lambda: old_packed_call(packed, **inputs), lambda: NEW_PACKED_CALL(packed, **inputs)),
        "data tolerances' row sums": (lambda: old_row_sums(T, x0 / D, True), lambda: new_row_sums(T, x0 / D, True)),
        "result's momenta": (lambda: old_p(x, T.p), lambda: T.momenta(x)),
        "result's trajectory (momenta included)": (lambda: old_trajectory(new, x, old_p),
                                                   lambda: trajectory_from_x(new, x)),
    }
    print(f"\n{name}: x {T.x_layout.size}, g {T.g_layout.size}")
    print(f"{'piece':42s} {'old us':>9s} {'new us':>9s} {'new/old':>8s}")
    for label, (old, new_f) in rows.items():
        a, b = alternate(old, new_f, calls)
        print(f"{label:42s} {1e6 * a:9.1f} {1e6 * b:9.1f} {b / a:8.3f}")
    state = {"previous": previous, "i": 0}

    def resolve(old):
        def run():
            swapped(old)
            if old:
                solve_module.trajectory_from_x = lambda problem, x: old_trajectory(problem, x, old_p)
            try:
                return solve(moved[state["i"] % 2], guess=previous, jit=True)
            finally:
                solve_module.trajectory_from_x = trajectory_from_x
                swapped(False)
        return run
    a, b = alternate(resolve(True), resolve(False), max(calls // 4, 50))
    print(f"{'raw re-solve, jit=True (IPOPT included)':42s} {1e6 * a:9.1f} {1e6 * b:9.1f} {b / a:8.3f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=2000)
    args = parser.parse_args(argv)
    print(f"dmoc from {dmoc.__file__}; load average {'%.2f %.2f %.2f' % os.getloadavg()} at the start")
    for name, (make, goals) in CASES.items():
        case(name, make, goals, args.calls)
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at the end")


if __name__ == "__main__":
    main()
