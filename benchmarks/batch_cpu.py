"""Benchmark: where the CPU of a `simulate_many` batch goes, process by process and thread
by thread (docs/performance.md, "Twelfth"): knife-edge runs (h = 0.01, compiled step,
v0 = (c, 0, 1)) on a 2-worker `dmoc.batch.Cluster` warmed up as in `batch.py`, several
batches in a row, against the serial loop and the runs in lockstep in this process.

Per batch, the CPU seconds of each thread of this process (the client's main thread; the
"IO loop" thread, which runs the client's connections, the LocalCluster's scheduler and
its nannies) and of each worker process's threads (its event loop, "MainThread", and the
thread that runs the tasks), from `psutil` (clock ticks: 10 ms resolution per thread, so
read medians). Run it from each checkout in turn
(``cd CHECKOUT && PYTHONPATH=. python benchmarks/batch_cpu.py``) to compare them.

    OMP_NUM_THREADS=1 python benchmarks/batch_cpu.py                 # 7 batches of 1000 runs
    OMP_NUM_THREADS=1 python benchmarks/batch_cpu.py --keep final
"""

import os
import resource
import threading
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import psutil  # noqa: E402

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.simulation.lockstep import simulate_runs  # noqa: E402

from batch_stream import knife_edge_batches  # noqa: E402

WORKERS = 2


def threads_cpu():
    """{thread name: CPU seconds} of this process's threads (those Python knows by name;
    the others summed as "other")."""
    names = {t.native_id: t.name for t in threading.enumerate()}
    seconds = {}
    for thread in psutil.Process().threads():
        name = names.get(thread.id, "other")
        name = "tasks" if name.startswith(("0-Dask-Default", "1-Dask-Default", "Dask-Default")) else name
        seconds[name] = seconds.get(name, 0.0) + thread.user_time + thread.system_time
    return seconds


def cpu_seconds():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def batch_cpu(cluster, disc, runs, keep):
    """(wall seconds, {"client <thread>" or "worker k <thread>": CPU seconds}) of one batch."""
    def snapshot():
        workers = cluster.client.run(threads_cpu)
        parts = {f"client {name}": s for name, s in threads_cpu().items()}
        for k, address in enumerate(sorted(workers)):
            parts.update({f"worker {k} {name}": s for name, s in workers[address].items()})
        return parts
    before = snapshot()
    tic = time.perf_counter()
    batch.simulate_many(disc, runs, keep=keep, client=cluster, progress=False)
    wall = time.perf_counter() - tic
    after = snapshot()
    return wall, {name: s - before.get(name, 0.0) for name, s in after.items()}


def main(argv=None):
    args, disc, runs = knife_edge_batches(__doc__.split("\n\n")[0], 7, argv)
    serial, lockstep = [], []
    for _ in range(3):
        tic = cpu_seconds()
        [dmoc.simulate(disc, **run) for run in runs]
        serial.append(cpu_seconds() - tic)
        tic = cpu_seconds()
        simulate_runs(disc, [dict(run, throw=False) for run in runs])
        lockstep.append(cpu_seconds() - tic)
    print(f"in this process: serial loop {np.median(serial) * 1e3:.0f} ms CPU, "
          f"in lockstep {np.median(lockstep) * 1e3:.0f} ms CPU (medians of 3)")
    with batch.Cluster(workers=WORKERS) as cluster:
        for keep in batch.KEEP:             # each worker's compiled step and verdict
            batch.simulate_many(disc, runs[:2 * WORKERS], keep=keep, client=cluster, progress=False)
        rows = [batch_cpu(cluster, disc, runs, args.keep) for _ in range(args.batches)]
    names = sorted({name for _, parts in rows for name in parts})
    table = {"wall": [wall for wall, _ in rows],
             "total CPU": [sum(parts.values()) for _, parts in rows],
             **{name: [parts.get(name, 0.0) for _, parts in rows] for name in names}}
    print(f"{'ms per batch':32s}" + "".join(f"{k + 1:>7d}" for k in range(args.batches)) + "  median")
    for name, values in table.items():
        if max(values) >= 0.005 or name in ("wall", "total CPU"):
            print(f"{name:32s}" + "".join(f"{1e3 * v:7.0f}" for v in values)
                  + f"  {1e3 * np.median(values):6.0f}")
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
