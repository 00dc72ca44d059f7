"""Benchmark: the CPU an `optimize_many` batch spends per item on its workers, in this process
(docs/performance.md, `batch_optimize_worker.py`): `--count` knife-edge parking problems at N = `--steps`
(goals (0, y, 0.1), y from 0.2 to 2.0, as benchmarks/batch.py), in chunks of `--chunk`
items (about what a worker gets: 0.5 s of solves), each chunk as a worker's task runs it,
the items unpickled and rebuilt with ``with_boundary`` on the kept solver:

- **alone**: each item solved and judged in turn (`item_guard.guarded_chunk`, the path of a batch
  with a `timeout`, and what every chunk did before the verdicts were grouped);
- **together**: the items solved in turn, the optima of the chunk judged together
  (`tasks._solved_then_judged`, a batch without a timeout);
- for reference, **optimize**: the loop of ``dmoc.optimize`` on the rebuilt problems
  (what a worker's task ran before it kept the solve and the verdict apart), and
  **solves only**: IPOPT's solves of the items, not judged (the floor of both paths).

They alternate in this one process, in reverse order every other round; prints the CPU seconds
(`time.process_time`) per item of each, medians over `--rounds` rounds, and checks that
"alone" and "together" give the same results bit for bit (cost, x, status, message,
verdict) as the serial ``dmoc.optimize``. Run it from a checkout:

    cd CHECKOUT && OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/batch_optimize_worker.py
"""

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import cloudpickle  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.batch import item_guard, shipping, tasks  # noqa: E402
from dmoc.optimal_control.solver.optimization_result import OptimizationResult  # noqa: E402
from dmoc.problems import knife_edge_parking  # noqa: E402


def chunk_calls(base, problems, options):
    """The (load, solve) pairs `tasks.optimize_chunk` makes of the items of `problems`
    (rebuilt from `base`), the shipped problem already unpacked."""
    items = [bytes(shipping.item("guess", (shipping.boundary(p), p.parameter_values, None)))
             for p in problems]
    calls = []
    for item in items:
        def load(item=item):
            return base, cloudpickle.loads(item)

        def solve(loaded):
            problem, guess = rebuilt(loaded)
            return problem, tasks.ipopt_solve(problem, guess=guess, options=options,
                                              throw=False)
        calls.append((load, solve))
    return calls


def alone(calls):
    """Each of `calls` solved and judged in turn (`item_guard.guarded_chunk`)."""
    return item_guard.guarded_chunk(OptimizationResult, [
        (load, lambda loaded, solve=solve: tasks._judged([solve(loaded)])[0])
        for load, solve in calls], None, None)[0]


def together(calls):
    """`calls` solved in turn, their optima judged together (`tasks._solved_then_judged`)."""
    return tasks._solved_then_judged(calls, None)[0]


def optimize_loop(calls):
    """``dmoc.optimize`` of each item's problem, rebuilt as `calls` rebuild it."""
    return [dmoc.optimize(problem, guess=guess, throw=False)
            for problem, guess in (rebuilt(load()) for load, _ in calls)]


def rebuilt(loaded):
    """(problem, guess) of a loaded item: the shipped problem ``with_boundary`` its data."""
    problem, (boundary, _, guess) = loaded
    return problem.with_boundary(**boundary), guess


def solves_only(calls):
    """IPOPT's solve of each item, not judged."""
    return [solve(load())[1] for load, solve in calls]


PATHS = {"alone": alone, "together": together, "optimize": optimize_loop,
         "solves only": solves_only}
CHECKED = ("alone", "together")


def batch_of(run, calls, chunk):
    """(CPU seconds, results) of `run` on `calls` in chunks of `chunk`."""
    tic, results = time.process_time(), []
    for first in range(0, len(calls), chunk):
        results += run(calls[first:first + chunk])
    return time.process_time() - tic, results


def same(a, b):
    """Whether two OptimizationResults agree bit for bit (but the times in their stats)."""
    return (a.x.tobytes() == b.x.tobytes() and np.float64(a.cost).tobytes() == np.float64(b.cost).tobytes()
            and (a.success, a.status, a.message, repr(a.verdict)) == (b.success, b.status, b.message, repr(b.verdict)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--count", type=int, default=500)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--chunk", type=int, default=31)
    args = parser.parse_args(argv)
    print("load average %.2f %.2f %.2f at start" % os.getloadavg())
    base = knife_edge_parking(args.steps)
    problems = [base.with_boundary(q_goal=[0.0, y, 0.1]) for y in np.linspace(0.2, 2.0, args.count)]
    serial = [dmoc.optimize(p, throw=False) for p in problems]
    calls = chunk_calls(base, problems, None)
    worker = tasks.distributed.get_worker
    tasks.distributed.get_worker = lambda: type("Worker", (), {"address": "this process"})
    try:
        spent = {name: [] for name in PATHS}
        for r in range(args.rounds):
            order = list(PATHS.items())
            for name, run in order if r % 2 == 0 else order[::-1]:     # no path always first
                seconds, results = batch_of(run, calls, args.chunk)
                assert name not in CHECKED or all(same(a, b) for a, b in zip(results, serial)), name
                spent[name].append(seconds)
    finally:
        tasks.distributed.get_worker = worker
    print(f"ms of CPU per item, {len(calls)} items at N = {args.steps} in chunks of "
          f"{args.chunk}, round by round:")
    for name, seconds in spent.items():
        print(f"  {name:12s} " + " ".join(f"{1e3 * s / len(calls):6.2f}" for s in seconds)
              + f"   median {1e3 * np.median(seconds) / len(calls):6.2f}")
    alone, together = (np.median(spent[name]) for name in CHECKED)
    print(f"together saves {1e3 * (alone - together) / len(calls):.2f} ms per item "
          f"({1 - together / alone:.1%}) at the medians; \"alone\" and \"together\" equal the "
          f"serial optimize's {len(calls)} results bit for bit")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
