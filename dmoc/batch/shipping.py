"""The client side of what a batch sends: each problem structure (or discretization) once,
as the bytes of a `Shipment` named by their digest, and each item as its data only.

Problems are grouped by their `structure`, the key by value of their NLP that
`optimize`'s solver cache keys on, however they were built. A problem travels as its
boundary data and parameter values when a problem already shipped of its structure
rebuilds it by ``with_boundary(...).with_parameters(...)`` (the same NLP, bounds, p and
step; docs/batch.md): the problems of ``base.with_boundary(...)`` and the problems built
one by one alike with other goals. Any other problem is shipped itself.
"""

import hashlib
import pickle

import cloudpickle
import numpy as np

from ..errors import DmocError, InputTypeError
from .tasks import pack_problem

_ARRAYS = ("lbx", "ubx", "lbg", "ubg", "p")
_SHARED = ("_disc", "_final_time", "_control_bounds", "_state_bounds", "_velocity_bounds", "_formulation",
           "_momentum_treatment", "_running", "_terminal", "_path")


def digest(data):
    """A short name of the bytes `data` (SHA-256)."""
    return hashlib.sha256(data).hexdigest()[:24]


def problem_items(problems, guesses):
    """(shipments {digest: bytes}, items [(digest, data)]): each item's data (`item`) is
    ``(boundary, parameter_values, guess)`` for `tasks.optimize_chunk`, to be applied to
    the problem shipped under its digest."""
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
        items.append((name, item(f"guesses[{i}]", (*data, guess))))
    return shipments, items


def run_items(discs, runs):
    """(shipments {digest: bytes}, items [(digest, data)]): one Discretization of each
    value shipped once (discretizations of equal ``key``, the system's and the rule's,
    and equal step h are one, however they were built), each run as ``item(run)`` for
    `tasks.simulate_chunk`. A Discretization object met again is looked up by identity
    (hashing its key costs about as much as an item)."""
    shipments, items, names, seen = {}, [], {}, {}
    for i, (disc, run) in enumerate(zip(discs, runs)):
        if id(disc) not in seen:
            value = (type(disc), disc.key, disc.h)
            if value not in names:
                data = pickled(f"disc[{i}]", disc)
                names[value] = digest(data)
                shipments[names[value]] = data
            seen[id(disc)] = disc, names[value]          # the disc kept: its id stays its own
        items.append((seen[id(disc)][1], item(f"runs[{i}]", run)))
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


# Types plain pickle writes as cloudpickle does (by value, or by reference to numpy, which
# every worker imports), in about a third of its time: the built-in scalars, and numpy's
# scalars of numbers (`_LEAVES`, looked up by exact type).
_LEAVES = frozenset((bool, int, float, complex, str, bytes, type(None))) | frozenset(
    kind for kind in np.sctypeDict.values() if np.dtype(kind).kind in "biufc")


def pickled(name, value):
    """``cloudpickle.dumps(value)``, or the same object as plain ``pickle.dumps`` writes it
    when `value` is plain data (`plain`); the worker task unpickles it."""
    try:
        return pickle.dumps(value, protocol=5) if plain(value) else cloudpickle.dumps(value)
    except Exception as err:
        raise InputTypeError(f"`{name}` cannot be pickled for the workers: "
                             f"{type(err).__name__}: {err}") from err


def item(name, value):
    """An item's data: ``bytes(item(name, value)) == pickled(name, value)``. Plain data
    (`plain`) is pickled when its chunk is submitted (`Plain`), so the workers start
    before the client has pickled every item; anything else now, by cloudpickle, so that
    an argument that cannot be pickled is refused before anything is submitted."""
    return Plain(value) if plain(value) else pickled(name, value)


class Plain:
    """Plain data (`plain`) whose bytes, ``pickle.dumps(value)``, are made the first time
    they are asked for (``bytes(data)``) and kept for a chunk submitted again."""

    __slots__ = ("value", "_bytes")

    def __init__(self, value):
        self.value, self._bytes = value, None

    def __bytes__(self):
        if self._bytes is None:
            self._bytes = pickle.dumps(self.value, protocol=5)
        return self._bytes


def plain(value, depth=0):
    """Whether `value` is numbers, strings, numpy arrays or scalars of numbers, and lists,
    tuples and dicts (of str keys) of them, nested at most 8 deep."""
    kind = type(value)
    if kind in _LEAVES:
        return True
    if depth >= 8:
        return False
    if kind is list or kind is tuple:
        return all(type(item) in _LEAVES or plain(item, depth + 1) for item in value)
    if kind is dict:
        return all(type(key) is str and (type(item) in _LEAVES or plain(item, depth + 1))
                   for key, item in value.items())
    return (kind is np.ndarray or isinstance(value, np.generic)) and value.dtype.kind in "biufc"
