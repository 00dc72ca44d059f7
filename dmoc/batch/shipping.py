"""The client side of what a batch sends: each problem structure (or discretization) once,
as the bytes of a `Shipment` named by their digest, and each item as its data only.

A problem travels as its boundary data and parameter values when a problem already
shipped rebuilds it by ``with_boundary(...).with_parameters(...)`` (the same NLP,
`structure`, bounds and p; docs/batch.md): the problems of ``base.with_boundary(...)``
and the problems built alike with other goals. Any other problem is shipped itself.
"""

import hashlib

import cloudpickle
import numpy as np

from ..errors import DmocError, InputTypeError
from .tasks import pack_problem

_ARRAYS = ("lbx", "ubx", "lbg", "ubg", "p")
_SHARED = ("_disc", "_final_time", "_control_bounds", "_state_bounds", "_formulation",
           "_momentum_treatment", "_running", "_terminal", "_path")


def digest(data):
    """A short name of the bytes `data` (SHA-256)."""
    return hashlib.sha256(data).hexdigest()[:24]


def problem_items(problems, guesses):
    """(shipments {digest: bytes}, items [(digest, bytes)]): each item's bytes are
    ``cloudpickle.dumps((boundary, parameter_values, guess))`` for `tasks.optimize_chunk`,
    to be applied to the problem shipped under its digest."""
    shipments, items, shipped = {}, [], {}     # shipped: structure -> [(problem, digest)]
    for i, (problem, guess) in enumerate(zip(problems, guesses)):
        data = boundary(problem), problem.parameter_values
        candidates = shipped.setdefault(problem.structure, [])
        name = next((name for base, name in candidates if rebuilds(base, problem, *data)), None)
        if name is None:
            packed = pack_problem(problem)
            name = digest(packed)
            shipments[name] = packed
            candidates.append((problem, name))
        items.append((name, pickled(f"guesses[{i}]", (*data, guess))))
    return shipments, items


def run_items(discs, runs):
    """(shipments {digest: bytes}, items [(digest, bytes)]): each distinct Discretization
    (by identity) shipped once, each run as ``cloudpickle.dumps(run)`` for
    `tasks.simulate_chunk`."""
    shipments, items, names = {}, [], {}
    for i, (disc, run) in enumerate(zip(discs, runs)):
        if id(disc) not in names:
            data = pickled(f"disc[{i}]", disc)
            names[id(disc)] = digest(data)
            shipments[names[id(disc)]] = data
        items.append((names[id(disc)], pickled(f"runs[{i}]", run)))
    return shipments, items


def boundary(problem):
    """The boundary data of `problem` as ``with_boundary`` keywords (None where free)."""
    return {k: [None if np.isnan(x) else float(x) for x in getattr(problem, k)]
            for k in ("q_start", "q_goal", "v_start", "v_goal")}


def rebuilds(base, problem, bounds, values):
    """Whether ``base.with_boundary(**bounds).with_parameters(**values)`` is `problem`:
    at once when `problem` was made that way from `base` (they share the NLP terms and
    every other part), else by comparing the rebuilt bounds, p and step with its own."""
    if base.transcription.separable is problem.transcription.separable and all(
            getattr(base, k) is getattr(problem, k) for k in _SHARED):
        return True
    try:
        rebuilt = base.with_boundary(**bounds)
        rebuilt = rebuilt.with_parameters(**values) if values else rebuilt
    except DmocError:       # e.g. a goal outside the base's state bounds
        return False
    return rebuilt.structure == problem.structure and rebuilt.disc.h == problem.disc.h and all(
        np.array_equal(getattr(rebuilt, k), getattr(problem, k)) for k in _ARRAYS)


def pickled(name, value):
    """``cloudpickle.dumps(value)``; the worker task unpickles it."""
    try:
        return cloudpickle.dumps(value)
    except Exception as err:
        raise InputTypeError(f"`{name}` cannot be pickled for the workers: "
                             f"{type(err).__name__}: {err}") from err
