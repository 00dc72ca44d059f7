"""Benchmark: the CPU a `simulate_many` batch spends per run outside Dask, in this process
(docs/performance.md, `batch_worker.py`): 1000 knife-edge runs of 1000 steps (h = 0.01,
compiled step, v0 = (c, 0, 1)) in chunks of 125, each chunk as a worker's task runs it
without a budget (`dmoc.batch.tasks._in_lockstep`: each run unpickled, the runs checked,
stepped in lockstep and concluded), then packed into a slot of shared memory as a worker
sends it (`PackedResults`), then read back and unpacked as the client receives it.

Prints the CPU time (`time.process_time`) per run of each part, medians over `--rounds`
rounds of the 1000 runs, and checks the results against the serial runs' bit for bit.
Run it from each checkout in turn, alternating, to compare them:

    cd CHECKOUT && OMP_NUM_THREADS=1 PYTHONPATH=. python benchmarks/batch_worker.py
"""

import argparse
import os
import pickle
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import cloudpickle  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.batch import sharing, shipping, tasks  # noqa: E402
from dmoc.batch.packing import PackedResults  # noqa: E402
from knife_runs import knife_edge_runs  # noqa: E402

CHUNK = 125
FIELDS = ("t", "q", "p", "lam", "u", "mu", "s")


def batch_parts(disc, runs, calls):
    """({part: CPU seconds} of one batch of `calls` in chunks of CHUNK, its results)."""
    spent, results = dict.fromkeys(("task", "pack", "client"), 0.0), []
    with sharing.Exchange() as share:
        for first in range(0, len(calls), CHUNK):
            tic = time.process_time()
            chunk, _ = tasks._in_lockstep(calls[first:first + CHUNK], False)
            spent["task"] += time.process_time() - tic
            tic = time.process_time()
            data = pickle.dumps(PackedResults(chunk, share), protocol=5)
            spent["pack"] += time.process_time() - tic
            del chunk
            tic = time.process_time()
            results += pickle.loads(data)
            spent["client"] += time.process_time() - tic
    return spent, results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--runs", type=int, default=1000)
    args = parser.parse_args(argv)
    disc, runs = knife_edge_runs(args.runs, 1000)
    serial = [dmoc.simulate(disc, **run) for run in runs]
    items = [bytes(shipping.item("runs", run)) for run in runs]
    calls = [(lambda item=item: (disc, cloudpickle.loads(item)), None) for item in items]
    worker = tasks.distributed.get_worker
    tasks.distributed.get_worker = lambda: type("Worker", (), {"address": "this process"})
    try:
        batch_parts(disc, runs, calls)                   # warm: memory reused from here on
        rounds = []
        for _ in range(args.rounds):
            spent, results = batch_parts(disc, runs, calls)
            assert all(getattr(a.trajectory, f).tobytes() == getattr(b.trajectory, f).tobytes()
                       for a, b in zip(results, serial) for f in FIELDS)
            rounds.append(spent)
    finally:
        tasks.distributed.get_worker = worker
    parts = {name: 1e6 * np.median([r[name] for r in rounds]) / len(runs) for name in rounds[0]}
    total = 1e6 * np.median([sum(r.values()) for r in rounds]) / len(runs)
    print(f"us of CPU per run, medians of {args.rounds} x {len(runs)} runs: "
          + ", ".join(f"{name} {value:.1f}" for name, value in parts.items())
          + f", total {total:.1f}; load average %.2f %.2f %.2f" % os.getloadavg())


if __name__ == "__main__":
    main()
