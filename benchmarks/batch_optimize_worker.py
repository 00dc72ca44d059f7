"""Benchmark: the CPU an `optimize_many` batch spends per item on its workers, in this process
(docs/performance.md, "Sixteenth"): `--count` knife-edge parking problems at N = `--steps`
(goals (0, y, 0.1), y from 0.2 to 2.0, as benchmarks/batch.py), in chunks of `--chunk`
items (about what a worker gets: 0.5 s of solves), each chunk as a worker's task runs it,
the items unpickled and rebuilt with ``with_boundary`` on the kept solver:

- **alone**: each item solved and judged in turn (`tasks._chunk`, the path of a batch
  with a `timeout`, and what every chunk did before the verdicts were grouped);
- **together**: the items solved in turn, the optima of the chunk judged together
  (`tasks._solved_then_judged`, a batch without a timeout).

The two alternate round by round in this one process; prints the CPU seconds
(`time.process_time`) per item of each, medians over `--rounds` rounds, and checks that
both give the same results bit for bit (cost, x, status, message, verdict) and the serial
``dmoc.optimize``'s. Run it from a checkout:

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
from dmoc.batch import shipping, tasks  # noqa: E402
from dmoc.optimize.optimization_result import OptimizationResult  # noqa: E402
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
            problem, (boundary, _, guess) = loaded
            problem = problem.with_boundary(**boundary)
            return problem, tasks.ipopt_solve(problem, guess=guess, options=options,
                                              throw=False)
        calls.append((load, solve))
    return calls


def alone(calls):
    """Each of `calls` solved and judged in turn (`tasks._chunk`)."""
    return tasks._chunk(OptimizationResult, [
        (load, lambda loaded, solve=solve: tasks._judged([solve(loaded)])[0])
        for load, solve in calls], None, None)[0]


def together(calls):
    """`calls` solved in turn, their optima judged together (`tasks._solved_then_judged`)."""
    return tasks._solved_then_judged(calls, None)[0]


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
        spent = {"alone": [], "together": []}
        for _ in range(args.rounds):
            for name, run in (("alone", alone), ("together", together)):
                seconds, results = batch_of(run, calls, args.chunk)
                assert all(same(a, b) for a, b in zip(results, serial)), name
                spent[name].append(seconds)
    finally:
        tasks.distributed.get_worker = worker
    ms = {name: 1e3 * np.median(s) / len(calls) for name, s in spent.items()}
    print("rounds (ms per item, alone / together): " + ", ".join(
        f"{1e3 * a / len(calls):.2f} / {1e3 * b / len(calls):.2f}"
        for a, b in zip(spent["alone"], spent["together"])))
    print(f"ms of CPU per item, medians of {args.rounds} x {len(calls)} items at N = {args.steps} "
          f"in chunks of {args.chunk}: alone {ms['alone']:.3f}, together {ms['together']:.3f}, "
          f"saved {ms['alone'] - ms['together']:.3f} ({1 - ms['together'] / ms['alone']:.1%}); "
          f"all {len(calls)} results equal the serial optimize's bit for bit")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
