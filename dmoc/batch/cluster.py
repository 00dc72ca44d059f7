"""Where a batch runs: a `Cluster` kept across calls, a LocalCluster of this machine
started for one call, a `distributed.Client`, or a scheduler reached by address (over
TCP, on this machine or another). Workers get one thread each, and BLAS one thread.
"""

import os
import sys

import dask
import distributed
from distributed.comm.addressing import parse_address
from distributed.comm.registry import get_backend
from distributed.deploy.spec import SpecCluster

from .._util import checks
from ..errors import InputError, InputTypeError
from .failures import SchedulerUnreachable, WorkersFailedToStart

# one BLAS/OpenMP thread per worker process: the workers, not BLAS threads, share the cores
WORKER_ENVIRONMENT = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}

# Seconds a LocalCluster whose start Ctrl-C cut short gets to close.
CLOSE_TIMEOUT = 5

# Dask's configuration for dmoc's LocalCluster (measured with benchmarks/batch.py):
LOCAL_CONFIG = {
    # Dask's nannies start their workers with MALLOC_TRIM_THRESHOLD_=65536, which hands
    # freed memory back to the system at once and turns glibc's adaptive thresholds off: a
    # CasADi / IPOPT solve then runs about 1.3x slower. The workers keep glibc's default,
    # unless the environment sets it.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    # Dask's housekeeping took 13 % of a core on an idle 2-worker cluster: the workers'
    # statistical profiler (every 10 ms), the event loops' tick (20 ms), the nannies'
    # memory monitor (100 ms) and the system monitor (500 ms). The profiler is off and the
    # others run every second or five, which keeps 1.5 %; a worker's death is still
    # noticed at once (its nanny sees the process exit).
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}


class Cluster:
    """A Dask cluster kept across batches: ``with Cluster() as cluster:`` then
    ``optimize_many(problems, client=cluster)`` as many times as needed; closed on exit.

    Parameters
    ----------
    address : str, optional
        A scheduler's address, e.g. ``"tcp://10.0.0.1:8786"``: connect to it (its workers
        are left running on exit). By default the address in Dask's configuration
        (``DASK_SCHEDULER_ADDRESS``), else a LocalCluster of this machine is started.
    workers : int, optional
        The LocalCluster's single-threaded worker processes (default ``os.cpu_count()``);
        only without an address.
    connect_timeout : float
        Seconds to reach the scheduler (else `SchedulerUnreachable`).
    security : distributed.Security, optional
        TLS certificates of the connection (a ``tls://`` address), or of the LocalCluster
        started, whose scheduler, workers and client then talk TLS only, e.g.
        ``distributed.Security.temporary()`` (docs/batch.md, "Security"). By default Dask's
        configuration (``distributed.comm.tls``).

    Attributes
    ----------
    client : distributed.Client
        The connection; it can be passed as ``client=`` too.
    """

    def __init__(self, address=None, *, workers=None, connect_timeout=5.0, security=None):
        if address is not None:
            checks.instance("address", address, str, "a scheduler address such as "
                            "'tcp://10.0.0.1:8786', or None")
        if address is not None and workers is not None:
            raise InputError("`workers` starts a LocalCluster; it cannot go with an "
                             f"`address` ({address!r}), whose workers run already.")
        if security is not None:
            checks.instance("security", security, distributed.Security,
                            "a distributed.Security, e.g. Security.temporary(), or None")
        workers = None if workers is None else checks.positive_int("workers", workers)
        self.client = connect(address if address is not None else _configured(),
                              checks.positive_float("connect_timeout", connect_timeout),
                              workers=workers, security=security, name="address")

    def close(self):
        """Close the connection, and the LocalCluster if this object started it."""
        close(self.client)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"Cluster({self.client.scheduler.address!r}, workers={len(self.client.nthreads())})"


def client_of(client, connect_timeout):
    """(Client, whether this call owns it and must close it) for `optimize_many`'s
    `client` argument."""
    if client is None:
        return connect(_configured(), connect_timeout), True
    if isinstance(client, str):
        return connect(client, connect_timeout), True
    if isinstance(client, Cluster):
        client = client.client
    if isinstance(client, distributed.Client):
        if client.status in ("closing", "closed"):
            raise InputError("`client` is a distributed.Client that is closed; pass an open "
                             "one, a dmoc.batch.Cluster, a scheduler address or None.")
        return client, False
    raise InputTypeError("`client` must be None (a LocalCluster on this machine), a "
                         "dmoc.batch.Cluster, a distributed.Client or a scheduler address "
                         f"such as 'tcp://host:8786'; got {type(client).__name__}.")


def connect(address, connect_timeout, *, workers=None, security=None, name="client"):
    """A new Client of the scheduler at `address` (the argument `name`), or of a new
    LocalCluster of `workers` single-threaded worker processes when `address` is None;
    with TLS when `security` (a distributed.Security) says so."""
    if address is None:
        with dask.config.set(LOCAL_CONFIG):
            cluster = _local_cluster(workers or os.cpu_count() or 1, security)
            try:
                return distributed.Client(cluster, security=security)
            except BaseException:
                cluster.close()
                raise
    _parsed(address, name)
    try:
        return distributed.Client(address, timeout=connect_timeout, security=security)
    except ValueError as err:       # an address distributed parses but cannot use
        raise InputError(f"`{name}` must be a scheduler address such as 'tcp://host:8786' or "
                         f"'tls://host:8786'; got {address!r} ({err}).") from err
    except TypeError as err:        # a tls:// address without certificates
        raise InputError(f"`{name}`={address!r} needs TLS certificates: pass "
                         "`dmoc.batch.Cluster(address, security=distributed.Security(...))` "
                         "or a distributed.Client made with `security=`, or configure "
                         f"`distributed.comm.tls` (docs/batch.md, \"Security\"); {err}") from err
    except (OSError, TimeoutError) as err:
        raise SchedulerUnreachable(
            f"could not reach a Dask scheduler at `{name}`={address!r} within "
            f"`connect_timeout`={connect_timeout:g} s ({type(err).__name__}: {err}). "
            "Check the address and that `dask scheduler` runs there.") from err


def _parsed(address, name):
    """Check that `address` (the argument `name`) is an address of one of Dask's transports,
    by Dask's own parsers, before anything connects or starts; else InputError."""
    try:
        scheme, location = parse_address(address)
        get_backend(scheme).get_address_host(location)
    except ValueError as err:
        raise InputError(f"`{name}` must be a scheduler address such as 'tcp://host:8786' or "
                         f"'tls://host:8786'; got {address!r} ({err}).") from err


def close(client):
    """Close `client`, and the cluster it started (a LocalCluster), if any."""
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()


def refuse_spawn_reimport():
    """Raise WorkersFailedToStart when called at the top level of a script that a spawned
    process is re-importing (as ``__mp_main__``): the script lacks its main guard, and
    without this check every worker process would start a cluster of its own."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "<module>" and frame.f_globals.get("__name__") == "__mp_main__":
            raise WorkersFailedToStart(
                "dmoc.batch was called while a worker process re-imported the script "
                f"{frame.f_globals.get('__file__')!r}: worker processes are spawned and "
                "import the main script again. Put the batch under "
                "`if __name__ == \"__main__\":`.")
        frame = frame.f_back


def _configured():
    """The scheduler address of Dask's configuration (``DASK_SCHEDULER_ADDRESS``), or None."""
    return dask.config.get("scheduler-address", None) or None


def _local_cluster(workers, security=None):
    refuse_spawn_reimport()
    started = set(SpecCluster._instances)
    try:
        return distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                        processes=True, dashboard_address=":0",
                                        env=WORKER_ENVIRONMENT, security=security)
    except KeyboardInterrupt:
        _drop_half_started(set(SpecCluster._instances) - started)
        raise
    except Exception as err:
        script = getattr(sys.modules.get("__main__"), "__file__", None)
        hint = (f" If {script!r} runs the batch at its top level, put the call under "
                "`if __name__ == \"__main__\":` (worker processes are spawned and "
                "import the main script again)." if script else "")
        raise WorkersFailedToStart(f"the LocalCluster's worker processes failed to "
                                   f"start ({type(err).__name__}: {err}).{hint}") from err


def _drop_half_started(clusters):
    """Close the LocalClusters whose start Ctrl-C cut short, as far as they let themselves
    be closed, and forget them, so that Dask's exit hook does not fail on them."""
    for cluster in clusters:
        try:
            cluster.close(timeout=CLOSE_TIMEOUT)
        except BaseException:       # a half-made cluster may refuse to close: forgotten all the same
            pass
        SpecCluster._instances.discard(cluster)
