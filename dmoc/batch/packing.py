"""How a chunk of `simulate_many`'s results travels from its worker to the client: every
trajectory field concatenated over the chunk's runs into one array (t, q, p over the
knots, lam, u, s over the steps, mu stacked), so that Dask moves seven arrays for the
chunk rather than seven per run; the client gets each run's Trajectory back as views of
those arrays (`Trajectory.unchecked`: no copy, no check; each run's rows are its own).
Dask's serialization sends the arrays as out-of-band frames (pickle protocol 5); to a
client on the worker's machine they go through shared memory (`dmoc.batch.shared_memory`).
"""

import dataclasses

import numpy as np

from ..principle.trajectory import Trajectory
from . import shared_memory

KNOT_FIELDS = ("t", "q", "p")            # N + 1 rows per run
STEP_FIELDS = ("lam", "u", "s")          # N rows per run


class PackedResults(list):
    """A list of SimulationResults that pickles as a few arrays (`pack`), written to a
    slot of the client's shared memory when `share` (`shared_memory.Exchange`) allows it;
    unpickled, it is a plain list of equal results (`unpack`), in the same order."""

    def __init__(self, results, share=None):
        super().__init__(results)
        self.share = share

    def __reduce__(self):
        file = shared_memory.SharedFile(self.share)
        try:
            heads, arrays = pack(self, file.allocate)
        except BaseException:      # the slot taken must not stay locked
            file.release()
            raise
        if arrays is not None and file.seal():
            return unpack_shared, (heads, file.path, file.layout)
        return unpack, (heads, arrays)


def pack(results, allocate=None):
    """(heads, arrays) of the SimulationResults `results`.

    Parameters
    ----------
    results : list of SimulationResult
    allocate : callable, optional
        ``allocate({name: (shape, dtype)})`` gives the arrays to fill
        (`shared_memory.SharedFile.allocate`), or None for new ones (the default).

    Returns
    -------
    heads : list, one per result
        (result without its trajectory, (N, h, variant, control_nodes, stage_nodes) of
        its trajectory), or (result, None) for a result kept whole: one without a
        trajectory, or whose trajectory's columns differ from the first packed one's.
    arrays : dict of ndarray, or None when no trajectory is packed
        ``t`` (K,), ``q``, ``p`` (K, n) with K the sum of N + 1 over the packed runs;
        ``lam``, ``u``, ``s`` (sum of N, ...); ``mu`` (runs, m).
    """
    widths = [(r, _widths(r.trajectory)) for r in results if r.trajectory is not None]
    packed = [r for r, width in widths if width == widths[0][1]]
    if not packed:
        return [(r, None) for r in results], None
    chosen = {id(r) for r in packed}
    columns = {name: [getattr(r.trajectory, name) for r in packed]
               for name in (*KNOT_FIELDS, *STEP_FIELDS, "mu")}
    shapes = {name: ((sum(len(a) for a in parts), *parts[0].shape[1:]), np.result_type(*parts))
              for name, parts in columns.items()}
    shapes["mu"] = ((len(packed), *columns["mu"][0].shape), shapes["mu"][1])
    arrays = allocate(shapes) if allocate is not None else None
    if arrays is None:
        arrays = {name: np.empty(shape, dtype) for name, (shape, dtype) in shapes.items()}
    for name in (*KNOT_FIELDS, *STEP_FIELDS):
        np.concatenate(columns[name], out=arrays[name])
    np.stack(columns["mu"], out=arrays["mu"])
    heads = []
    for r in results:
        if id(r) not in chosen:
            heads.append((r, None))
            continue
        traj = r.trajectory
        heads.append((dataclasses.replace(r, trajectory=None),
                      (traj.steps, traj.h, traj.variant, traj.control_nodes, traj.stage_nodes)))
    return heads, arrays


def unpack(heads, arrays):
    """The list of results `pack` made `heads` and `arrays` of, each packed trajectory
    made of views of `arrays`."""
    results, knot, step, run = [], 0, 0, 0
    for result, shape in heads:
        if shape is not None:
            steps, h, variant, control_nodes, stage_nodes = shape
            knots, rows = slice(knot, knot + steps + 1), slice(step, step + steps)
            t, q, p = (arrays[name][knots] for name in KNOT_FIELDS)
            lam, u, s = (arrays[name][rows] for name in STEP_FIELDS)
            result.trajectory = Trajectory.unchecked(t, q, p, lam, u, h, variant, arrays["mu"][run],
                                                     s, control_nodes, stage_nodes)
            knot, step, run = knot + steps + 1, step + steps, run + 1
        results.append(result)
    return results


def unpack_shared(heads, path, layout):
    """`unpack` of arrays that a `shared_memory.SharedFile` put in the slot `path` (copied out)."""
    return unpack(heads, shared_memory.read(path, layout))


def _widths(traj):
    """The columns of each field of `traj`, which a concatenation needs equal."""
    return tuple(getattr(traj, name).shape[1:] for name in (*KNOT_FIELDS, *STEP_FIELDS, "mu"))
