"""A batch over TLS on loopback (docs/batch.md, "Security"): a `dmoc.batch.Cluster` with
``distributed.Security.temporary()`` runs its scheduler on a ``tls://127.0.0.1`` address
and its worker processes connect over TLS; the results equal the serial in-process
`dmoc.optimize` and `dmoc.simulate` (the oracle), and a client without the certificate is
refused by the scheduler."""

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
pytest.importorskip("cryptography", reason="distributed.Security.temporary() needs cryptography")

import dmoc  # noqa: E402
from dmoc import batch  # noqa: E402
from dmoc.errors import DmocError  # noqa: E402


def test_a_batch_over_tls_gives_the_serial_results_and_refuses_clients_without_the_key():
    problems = [dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), 0.2), 20,
                                           q_start=[0, 0, 0], q_goal=[0.0, y, 0.1])
                for y in (0.5, 1.0, 1.5)]
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.05)
    runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 40} for c in (0.5, 1.0)]
    with batch.Cluster(workers=1, security=distributed.Security.temporary()) as cluster:
        address = cluster.client.scheduler.address
        assert address.startswith("tls://127.0.0.1:")
        assert all(w.startswith("tls://127.0.0.1:") for w in cluster.client.nthreads())
        optima = batch.optimize_many(problems, client=cluster, progress=False)
        sims = batch.simulate_many(disc, runs, client=cluster, progress=False)
        with pytest.raises(DmocError, match="`client`"):      # no certificate, no connection
            batch.optimize_many(problems, client=address, progress=False, connect_timeout=2)
    for problem, got in zip(problems, optima):
        want = dmoc.optimize(problem)
        assert got.success and abs(got.cost - want.cost) <= 1e-10
    for run, got in zip(runs, sims):
        assert np.array_equal(got.trajectory.q, dmoc.simulate(disc, **run).trajectory.q)


def test_a_cluster_refuses_a_security_that_is_not_one():
    with pytest.raises(TypeError, match="`security` must be a distributed.Security"):
        batch.Cluster(workers=1, security="tls")
