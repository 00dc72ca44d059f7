"""Many runs of the Dirac integrator in lockstep: runs that share a stepper (the same step
residual, tol, max_iter and jit), h and their number of steps N take each chunk of
steps together, the horizon of that chunk evaluated for all of them in one call
(`DiracStepper.horizons_of`, CasADi's map of the same horizon `simulate` calls) and
their steps accepted at once. A run whose step is not accepted leaves the lockstep at
that step and goes on alone, as `simulate` would have gone on there
(`DiracStepper.resume`): every result equals ``simulate``'s bit for bit, at a fraction of
its cost per run in Python (benchmarks/batch.py).
"""

import threading
import time

import numpy as np

from .preparation import memory_needed, prepare_runs
from .time_stepping import conclude, conclude_group
from .step_blocks import LOCKSTEP, chunk_length

# the most bytes of arrays (`memory_needed`) one group of runs in lockstep holds at once
# beyond their results: about 35 knife-edge runs of 1000 steps. Larger groups gain nothing
# (the runs go through the compiled horizon LOCKSTEP at a time) and touch more memory
# for the first time in a batch that is larger than the ones before.
GROUP_BYTES = 1 << 23

_SCRATCH = threading.local()        # the memory of `_scratch`, one per thread


def simulate_lockstep(runs, *, final=False, memory=np.empty):
    """`simulate` of each of `runs` (`preparation.Run`, from `prepare_runs`), the runs of each
    of their `groups` in lockstep: the SimulationResults in the order of `runs`, each
    what ``simulate`` returns for the same arguments but ``stats["wall_time"]`` (its
    group's time so far), its trajectory of the last knot only when `final`
    (`conclude_group`: the trajectories of a group's runs that completed every step are
    rows of one array per field, all in one float array ``memory(size)`` of shape
    (size,) per group: a new one by default, a piece of the client's shared memory in a
    batch, `dmoc.batch.packing.ChunkMemory`). With ``throw``, a failed run raises as
    ``simulate`` does once its group has run."""
    results = [None] * len(runs)
    for members in groups(runs):
        group = [runs[i] for i in members]
        if len(group) == 1:           # alone: no lockstep to gain, no scratch memory to keep
            run = group[0]
            concluded = [conclude(run, run.stepper.run(run.start, run.controls, run.disc.h),
                                  final=final)]
        else:
            controls = _stacked([run.controls for run in group])
            concluded = conclude_group(group, controls, *run_lockstep(
                group[0].stepper, np.array([run.start for run in group]), controls,
                group[0].disc.h), final=final, memory=memory)
        for i, result in zip(members, concluded):
            results[i] = result
    return results


def simulate_runs(disc, runs):
    """``[simulate(disc, **run, throw=False) for run in runs]`` in lockstep
    (`simulate_lockstep`): the same results but the wall times, in less time.

    Parameters
    ----------
    disc : Discretization
    runs : sequence of dict
        Keyword arguments of `simulate` for each run, as for `dmoc.batch.simulate_many`.

    Returns
    -------
    list of SimulationResult
        In the order of `runs`. A bad argument raises (InputError) as `simulate` does.

    Examples
    --------
    >>> import dmoc
    >>> from dmoc.simulation.lockstep import simulate_runs
    >>> disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    >>> runs = [{"q0": [0, 0, 0], "v0": [c, 0, 1], "steps": 10} for c in (0.5, 1.0, 2.0)]
    >>> [r.trajectory.q.shape for r in simulate_runs(disc, runs)]
    [(11, 3), (11, 3), (11, 3)]
    """
    prepared = prepare_runs(disc, [dict(run, throw=False) for run in runs])
    for run in prepared:
        if isinstance(run, Exception):
            raise run
    return simulate_lockstep(prepared)


def _stacked(controls):
    """The runs' `controls` (N, n_controls) as one array (R, N, n_controls): a read-only
    view when they are one array (`prepare_runs` shares the zeros), else a copy."""
    if all(c is controls[0] for c in controls):
        return np.broadcast_to(controls[0], (len(controls),) + controls[0].shape)
    return np.array(controls)


def groups(runs):
    """Lists of indices into `runs` of the runs that step in lockstep: the same stepper,
    h and number of steps; at most as many runs as hold GROUP_BYTES of arrays
    (`memory_needed`), so that a group's arrays stay a bounded multiple of one run's."""
    found = {}
    for i, run in enumerate(runs):
        key = (id(run.stepper), run.disc.h, run.controls.shape[0])
        found.setdefault(key, []).append(i)
    split = []
    for members in found.values():
        first = runs[members[0]]
        most = max(1, GROUP_BYTES // memory_needed(first.disc, first.controls.shape[0]))
        split.extend(members[j:j + most] for j in range(0, len(members), most))
    return split


def run_lockstep(stepper, starts, controls, h):
    """`stepper.run` of R runs that start from `starts` (R, state.size) under `controls`
    (R, N, n_controls), chunk by chunk together: (states (R, N+1, state.size), outputs
    (R, N, out.size), one tuple of `DiracStepper.run` per run, in order, whose arrays are
    views of those), all of this thread's scratch memory (`_scratch`), valid until its
    next call (`conclude_group` copies them). A run whose step k the fast path does
    not converge goes on alone from k (`DiracStepper.resume`). On a KeyboardInterrupt
    every run still in lockstep keeps the steps of the chunks before (interrupted, as
    `run`)."""
    R, N = controls.shape[:2]
    S, O, widest = stepper.state.size, stepper.out.size, chunk_length(N)
    arrays = _scratch({"acc": (R, N + 1, S), "out": (R, N, O), "following": R * widest * S,
                       "per_step": R * widest * O})
    acc, out = arrays["acc"], arrays["out"]
    acc[:, 0] = starts
    outcomes = [None] * R
    active, k = np.arange(R), 0
    try:
        while k < N and active.size:
            c = chunk_length(N - k)
            runs = slice(None) if active.size == R else active      # all: no gather, no scatter
            following = arrays["following"][:active.size * c * S].reshape(active.size, c, S)
            per_step = arrays["per_step"][:active.size * c * O].reshape(active.size, c, O)
            stepper.native_if_due()
            tic = time.perf_counter()
            _evaluate(stepper, acc[runs, k], controls[runs, k:k + c], h, following, per_step)
            if not stepper.native:
                stepper.vm_seconds += time.perf_counter() - tic
            acc[runs, k + 1:k + 1 + c], out[runs, k:k + c] = following, per_step
            ok = stepper.accepted(per_step.reshape(-1, O)).reshape(-1, c)
            whole = ok.all(axis=1)
            for i, steps_ok in zip(active[~whole], ok[~whole]):
                outcomes[i] = stepper.resume(acc[i], out[i], controls[i], h,
                                             k + int(np.argmin(steps_ok)), redo=True)
                if outcomes[i][4]:              # interrupted while alone
                    raise KeyboardInterrupt
            active = active[whole]
            k += c
    except KeyboardInterrupt:
        for i in active:
            if outcomes[i] is None:
                outcomes[i] = (acc[i, :k + 1], out[i, :k], None, 0, True, [])
        return acc, out, outcomes
    for i in active:
        outcomes[i] = (acc[i], out[i], None, 0, False, [])
    return acc, out, outcomes


def _evaluate(stepper, states, controls, h, following, per_step):
    """Write to `following` (A, c, state.size) and `per_step` (A, c, out.size) the fast
    path's next states and outputs of c steps of A runs from `states` (A, state.size)
    under `controls` (A, c, n_controls): the runs in blocks of LOCKSTEP, then of the
    powers of two that make up the rest, each block one call of the mapped horizon."""
    A, c = controls.shape[:2]
    states, controls = np.ascontiguousarray(states), np.ascontiguousarray(controls, dtype=float)
    steps = np.full(min(A, LOCKSTEP) * c, float(h))
    first = 0
    while first < A:
        width = min(LOCKSTEP, 1 << ((A - first).bit_length() - 1))
        block = slice(first, first + width)
        buffer, evaluate = stepper.horizons_of(c, width)
        for i, a in enumerate((states[block], controls[block], steps[:width * c])):
            buffer.set_arg(i, memoryview(a))
        buffer.set_res(0, memoryview(following[block]))
        buffer.set_res(1, memoryview(per_step[block]))
        evaluate()
        first += width


def _scratch(shapes):
    """Float arrays of the `shapes` ({name: shape}) in memory this thread reuses from call
    to call (2 GROUP_BYTES, about what a group needs, allocated and touched once; larger
    ones are fresh each time): a group's arrays are megabytes, which fresh allocations
    would fault in page by page each time, and a later, larger batch with them."""
    sizes = {name: int(np.prod(shape)) for name, shape in shapes.items()}
    total = sum(sizes.values())
    memory = getattr(_SCRATCH, "memory", None)
    if memory is None or memory.size < total:
        memory = np.empty(max(total, 2 * GROUP_BYTES // 8))
        if 8 * total <= 2 * GROUP_BYTES:
            memory.fill(0.0)          # its pages faulted in now, by the thread's first group
            _SCRATCH.memory = memory
    arrays, at = {}, 0
    for name, shape in shapes.items():
        arrays[name] = memory[at:at + sizes[name]].reshape(shape)
        at += sizes[name]
    return arrays
