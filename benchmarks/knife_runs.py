"""The knife-edge runs that the simulate benchmarks time (`batch.py`, `batch_worker.py`):
shared code of those scripts, no Dask needed."""

import numpy as np

import dmoc
from dmoc._util import compiled


def knife_edge_runs(count, steps):
    """(Discretization, runs) of the simulate benchmarks: the knife edge at h = 0.01 and
    `count` runs of `steps` steps from rest at the origin with v0 = (c, 0, 1), c from 0.5
    to 2, compiled to C where there is a compiler (the same path serially and on the
    workers)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.01)
    jit = compiled.compiler() is not None
    return disc, [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": steps, "jit": jit}
                  for c in np.linspace(0.5, 2.0, count)]
