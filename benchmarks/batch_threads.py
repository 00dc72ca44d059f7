"""Benchmark: where a `simulate_many` batch spends CPU, per process and thread, read from
/proc (utime + stime of each thread, Linux only), against the serial loop in the same run
(docs/performance.md, "Batches that scale").

1000 knife-edge runs of 1000 steps (h = 0.01, compiled step) on a 2-worker
`dmoc.batch.Cluster` already running and warmed up, `--repeat` rounds of the serial loop
then a batch with trajectories and one with ``keep="final"``; prints, per batch, the CPU
seconds of the client process's threads (its main thread, the event loop that runs the
client, the scheduler and the nannies, others) and of each worker's threads (the task
thread, the event loop, others), and the cpu bound 2 x serial CPU / batch CPU.

    python benchmarks/batch_threads.py --repeat 3
"""

import argparse
import os
import threading
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from knife_runs import knife_edge_runs  # noqa: E402

TICKS = os.sysconf("SC_CLK_TCK")


def threads():
    """{thread id: (name, CPU seconds)} of this process, from /proc."""
    found = {}
    for tid in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{tid}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        name = stat[stat.index("(") + 1:stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2:].split()
        found[int(tid)] = (name, (int(fields[11]) + int(fields[12])) / TICKS)
    return found


def by_kind():
    """{thread: CPU seconds} of this process's threads, named by Python's name of the
    thread where it has one ("MainThread": a worker's event loop; "IO loop": the client's,
    which runs the client, the scheduler and the nannies; a worker's task thread is
    "...Dask-Default-Threads-..."), else "other"."""
    named = {t.native_id: t.name for t in threading.enumerate()}
    total = {}
    for tid, (_, seconds) in threads().items():
        name = named.get(tid, "other")
        name = "task thread" if "Dask-Default-Threads" in name or "ThreadPoolExecutor" in name else name
        total[name] = total.get(name, 0.0) + seconds
    return total


def difference(after, before):
    return {k: after.get(k, 0.0) - before.get(k, 0.0) for k in after}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--count", type=int, default=1000)
    args = parser.parse_args(argv)
    disc, runs = knife_edge_runs(args.count, 1000)
    dmoc.simulate(disc, **runs[0])
    print("load average %.2f %.2f %.2f" % os.getloadavg())
    with batch.Cluster(workers=2) as cluster:
        for keep in ("trajectory", "final"):
            batch.simulate_many(disc, runs[:8], keep=keep, client=cluster, progress=False)
        for _ in range(args.repeat):
            tic, cpu = time.perf_counter(), time.process_time()
            [dmoc.simulate(disc, **run) for run in runs]
            serial = time.process_time() - cpu
            print(f"serial loop: {time.perf_counter() - tic:.3f} s wall, {serial:.3f} s CPU")
            for keep in ("trajectory", "final"):
                workers, client = cluster.client.run(by_kind), by_kind()
                tic = time.perf_counter()
                batch.simulate_many(disc, runs, keep=keep, client=cluster, progress=False)
                wall = time.perf_counter() - tic
                client = difference(by_kind(), client)
                workers = {w: difference(after, workers[w])
                           for w, after in cluster.client.run(by_kind).items()}
                total = sum(client.values()) + sum(sum(w.values()) for w in workers.values())
                print(f"  keep={keep!r}: {wall:.3f} s wall, speed-up {serial / wall:.2f}, "
                      f"cpu bound {2 * serial / total:.2f}; batch CPU {total:.3f} s")
                for who, parts in (("client", client), *(("worker", w) for w in workers.values())):
                    print(f"    {who:8s} " + ", ".join(f"{k} {v:.3f}" for k, v in sorted(parts.items())
                                                     if v >= 0.005))
    print("load average %.2f %.2f %.2f at end" % os.getloadavg())


if __name__ == "__main__":
    main()
