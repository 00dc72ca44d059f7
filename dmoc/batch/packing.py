"""How a chunk of `simulate_many`'s results travels from its worker to the client: the
trajectories' arrays (t, q, p, lam, u, s, mu of every run) lie in one buffer of floats
and each result carries where its own are, so that Dask moves one array for the chunk
rather than seven per run; the client gets each run's Trajectory back as views of that
buffer (`Trajectory.unchecked`: no copy, no check; each run's arrays are its own).

On the worker the buffer is the chunk's `ChunkMemory`: the runs stepped in lockstep copy
their trajectories straight into it (`dmoc.simulation.lockstep.simulate_lockstep`'s
`memory`), and for a client on the worker's machine it is a slot of the client's shared
memory (`dmoc.batch.shared_memory`), so that the arrays are written once, into the pages
the client's results keep, and no chunk allocates memory of its own for them. Elsewhere Dask's
serialization sends the buffer as an out-of-band frame (pickle protocol 5).
"""

import dataclasses
import math

import numpy as np

from ..principle.trajectory import Trajectory
from ..principle.trajectory_fields import copied_into
from . import shared_memory, slot_writer

FIELDS = ("t", "q", "p", "lam", "u", "s", "mu")


class ChunkMemory:
    """Float memory for the trajectories of one chunk on its worker, handed out in
    consecutive pieces (`take`): pieces of a slot of the client's shared memory
    (`slot_writer.SharedFile`) once a piece reaches `shared_memory.MIN_BYTES` and a free
    slot reaches this worker (then every later piece too, the slot grown); else new
    arrays, which `pack` copies.

    Parameters
    ----------
    share : tuple or None
        The client's `shared_memory.Exchange` value, or None (no slot: new arrays).
    """

    def __init__(self, share=None):
        self.file = slot_writer.SharedFile(share)
        self.used = 0             # floats of the slot handed out, after its HEADER
        self._mappings = []       # (address, mapping) of each mapping a piece was taken from

    def take(self, count):
        """A writable float array of shape (count,): the next `count` floats of the slot,
        or a new array."""
        memory = self.file.reserve(8 * (self.used + count))
        if memory is None:
            return np.empty(count)
        start = shared_memory.HEADER + 8 * self.used
        piece = np.frombuffer(memory, float, count, start)
        if not self._mappings or self._mappings[-1][1] is not memory:
            self._mappings.append((piece.ctypes.data - start, memory))
        self.used += count
        return piece

    def position(self, array):
        """The index among the slot's floats (after its HEADER) of the first of `array`'s,
        when `array` is a C-contiguous float array inside the pieces taken from the slot;
        else None."""
        if not self.file.held or array.dtype != float or not array.flags.c_contiguous:
            return None
        for base, memory in self._mappings:
            start = array.ctypes.data - base - shared_memory.HEADER
            if (0 <= start and start % 8 == 0 and start + array.nbytes <= 8 * self.used
                    and shared_memory.HEADER + start + array.nbytes <= len(memory)):
                return start // 8
        return None


class PackedResults(list):
    """A list of SimulationResults that pickles as one buffer (`pack`): the slot of its
    `memory` (`ChunkMemory`) when the arrays are there, sealed for the client; else an
    array Dask sends. Unpickled, it is a plain list of equal results (`unpack`), in the
    same order. It is packed once: pickled again, it gives the same slot (which the client
    reads once) or buffer; once sent through a slot, its own arrays are the client's to
    reuse."""

    def __init__(self, results, memory=None):
        super().__init__(results)
        self.memory = memory if memory is not None else ChunkMemory()
        self._sent = None

    def __reduce__(self):
        if self._sent is None:
            try:
                heads, data = pack(self, self.memory)
            except BaseException:      # the slot taken must not stay locked
                self.memory.file.release()
                raise
            if data is None:
                file = self.memory.file
                file.seal({"data": (0, np.dtype(float).str, (self.memory.used,))})
                self._sent = unpack_shared, (heads, file.path, file.layout)
            else:
                self._sent = unpack, (heads, data)
        return self._sent


def pack(results, memory):
    """(heads, data) of the SimulationResults `results`, their trajectories' arrays placed
    in `memory`'s slot or in `data`.

    Parameters
    ----------
    results : list of SimulationResult
    memory : ChunkMemory
        Arrays in its slot stay where they are; the others are copied into it.

    Returns
    -------
    heads : list, one per result
        (result without its trajectory, (h, variant, control_nodes, stage_nodes, places)
        of its trajectory, places the (start, shape) of each of FIELDS in the buffer), or
        (result, None) for a result kept whole: one without a Trajectory (none, or a
        RotationTrajectory), or with an array that is not of floats.
    data : ndarray of float, shape (floats,), or None
        None when every array is in `memory`'s slot (its first ``memory.used`` floats);
        else the buffer, all the arrays copied into it, and the slot, if any, let go.
    """
    fields = [_fields(r.trajectory) for r in results]
    arrays = [a for each in fields if each is not None for a in each]
    starts = [memory.position(a) if a.size else 0 for a in arrays]
    missing = [i for i, start in enumerate(starts) if start is None]
    if missing:
        piece = memory.take(sum(arrays[i].size for i in missing))
        at = memory.position(piece)
        if at is not None:                  # in the slot: copied there
            copied_into(piece, [arrays[i] for i in missing])
            for i, start in zip(missing, _starts([arrays[i] for i in missing], at)):
                starts[i] = start
            missing = []
    data = None
    if missing or not memory.file.held:
        data = np.empty(sum(a.size for a in arrays))
        copied_into(data, arrays)
        starts = _starts(arrays, 0)
        memory.file.release()
    return _heads(results, fields, starts), data


def _starts(arrays, at):
    """The index of the first float of each of `arrays` laid out one after another from
    index `at` (`copied_into`)."""
    return np.cumsum([at] + [a.size for a in arrays])[:-1].tolist()


def _fields(traj):
    """The arrays of FIELDS of `traj`, or None when it is not a Trajectory (none, or a
    RotationTrajectory, which travels whole with its result) or one of them is not an
    array of floats."""
    if not isinstance(traj, Trajectory):
        return None
    arrays = [getattr(traj, name) for name in FIELDS]
    return arrays if all(isinstance(a, np.ndarray) and a.dtype == float for a in arrays) else None


def _heads(results, fields, starts):
    """The heads of `pack`: each result with the places of its `fields` (`starts`, in
    order), or whole."""
    heads, start = [], iter(starts)
    for r, arrays in zip(results, fields):
        if arrays is None:
            heads.append((r, None))
            continue
        traj = r.trajectory
        places = tuple((next(start), a.shape) for a in arrays)
        heads.append((dataclasses.replace(r, trajectory=None),
                      (traj.h, traj.variant, traj.control_nodes, traj.stage_nodes, places)))
    return heads


def unpack(heads, data):
    """The list of results `pack` made `heads` and `data` of, each packed trajectory made
    of views of `data`."""
    results = []
    for result, shape in heads:
        if shape is not None:
            h, variant, control_nodes, stage_nodes, places = shape
            t, q, p, lam, u, s, mu = (data[start:start + math.prod(dims)].reshape(dims)
                                      for start, dims in places)
            result.trajectory = Trajectory.unchecked(t, q, p, lam, u, h, variant, mu, s,
                                                     control_nodes, stage_nodes)
        results.append(result)
    return results


def unpack_shared(heads, path, layout):
    """`unpack` of the buffer a `slot_writer.SharedFile` put in the slot `path` (copied out)."""
    return unpack(heads, shared_memory.read(path, layout)["data"])
