"""Benchmark: where the workers of a `simulate_many` batch wait, from Dask's task stream
(docs/performance.md, "Eleventh"): knife-edge runs (h = 0.01, compiled step, v0 =
(c, 0, 1)) on a 2-worker `dmoc.batch.Cluster` warmed up as in `batch.py`, several batches
in a row. Idle times are what load inflates least: a worker preempted while it computes
still counts as computing. Run it from each checkout in turn
(``cd CHECKOUT && PYTHONPATH=. python benchmarks/batch_stream.py``) to compare them.

Per batch: its wall time; the CPU of this process (client, scheduler, nannies); the
tasks; **idle**, 2 x wall less the time the two workers computed; **first 150 ms**, each
worker's idle time in the batch's first 150 ms (mean of the two); **end gap**, the time
between the two workers' last stops; **collect**, from the last stop to the call's return.

    OMP_NUM_THREADS=1 python benchmarks/batch_stream.py                 # 5 batches of 1000 runs
    OMP_NUM_THREADS=1 python benchmarks/batch_stream.py --keep final --batches 9
"""

import argparse
import os
import resource
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import distributed  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from knife_runs import knife_edge_runs  # noqa: E402

WORKERS = 2
EARLY = 0.15        # seconds at the start of a batch whose idle time is counted apart
COLUMNS = ("wall ms", "client CPU ms", "tasks", "idle ms", "first 150 ms", "end gap ms", "collect ms")


def computing(stream):
    """{worker: [(start, stop), ...]} of the tasks' computations in a task stream."""
    spans = {}
    for task in stream.data:
        for part in task["startstops"]:
            if part["action"] == "compute":
                spans.setdefault(task["worker"], []).append((part["start"], part["stop"]))
    return spans


def row(spans, start, stop, cpu, tasks):
    """The figures of COLUMNS of one batch called at `start` and returned at `stop`
    (seconds of ``time.time()``), in ms but the tasks."""
    busy = sum(b - a for intervals in spans.values() for a, b in intervals)
    early = np.mean([EARLY - sum(max(0.0, min(b, start + EARLY) - max(a, start))
                                 for a, b in intervals) for intervals in spans.values()])
    lasts = [max(b for _, b in intervals) for intervals in spans.values()]
    seconds = (stop - start, cpu, None, WORKERS * (stop - start) - busy, early,
               max(lasts) - min(lasts), stop - max(lasts))
    return [tasks if s is None else 1e3 * s for s in seconds]


def knife_edge_batches(description, batches, argv=None):
    """(arguments, Discretization, runs) of the batch benchmarks: the command line
    (--count, --steps, --batches with default `batches`, --keep) parsed and the knife-edge
    runs it asks for (h = 0.01, compiled step where there is a compiler, v0 = (c, 0, 1),
    c from 0.5 to 2); prints where dmoc comes from and the load average."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--count", type=int, default=1000, help="runs per batch")
    parser.add_argument("--steps", type=int, default=1000, help="steps per run")
    parser.add_argument("--batches", type=int, default=batches)
    parser.add_argument("--keep", choices=batch.KEEP, default="trajectory")
    args = parser.parse_args(argv)
    print(f"dmoc from {os.path.dirname(dmoc.__file__)}, load average %.2f %.2f %.2f" % os.getloadavg())
    return (args, *knife_edge_runs(args.count, args.steps))


def main(argv=None):
    args, disc, runs = knife_edge_batches(__doc__.split("\n\n")[0], 5, argv)
    rows = []
    print(" ".join(f"{name:>13s}" for name in COLUMNS))
    with batch.Cluster(workers=WORKERS) as cluster:
        for keep in batch.KEEP:             # each worker's compiled step and verdict
            batch.simulate_many(disc, runs[:2 * WORKERS], keep=keep, client=cluster, progress=False)
        for _ in range(args.batches):
            with distributed.get_task_stream(client=cluster.client) as stream:
                start, cpu = time.time(), resource.getrusage(resource.RUSAGE_SELF)
                batch.simulate_many(disc, runs, keep=args.keep, client=cluster, progress=False)
                stop, used = time.time(), resource.getrusage(resource.RUSAGE_SELF)
            cpu = used.ru_utime + used.ru_stime - cpu.ru_utime - cpu.ru_stime
            rows.append(row(computing(stream), start, stop, cpu, len(stream.data)))
            print(" ".join(f"{x:13.0f}" for x in rows[-1]))
    print(" ".join(f"{x:13.0f}" for x in np.median(np.array(rows), axis=0)), " medians")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
