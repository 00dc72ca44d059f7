"""A bounded cache keyed by value, for the objects that are costly to build (step
residuals, compiled steps, Dirac differentials, IPOPT solvers): least recently used entries
are dropped, so compiled code does not stay alive forever; `clear_caches` empties them all."""

import weakref
from collections import OrderedDict

from ..errors import InputError

_ALL = weakref.WeakSet()


class BoundedCache:
    """At most `maxsize` values, built on first use by ``get(key, build)``; `name` says
    what it holds, for `clear_caches`.

    >>> cache = BoundedCache(1, "example")
    >>> cache.get("a", lambda: 1), cache.get("b", lambda: 2), len(cache)
    (1, 2, 1)
    """

    def __init__(self, maxsize, name):
        self.maxsize, self.name, self._values = maxsize, name, OrderedDict()
        _ALL.add(self)

    def get(self, key, build):
        """The value of `key`, built by ``build()`` if it is not held."""
        if key in self._values:
            self._values.move_to_end(key)
            return self._values[key]
        value = self._values[key] = build()
        while len(self._values) > self.maxsize:
            self._values.popitem(last=False)
        return value

    def clear(self):
        """Drop every value."""
        self._values.clear()

    def __len__(self):
        return len(self._values)

    def __contains__(self, key):
        return key in self._values


def cache_names():
    """The names of the caches `clear_caches` can empty, sorted."""
    return tuple(sorted({cache.name for cache in list(_ALL)}))


def clear_caches(*names):
    """Empty the caches dmoc keeps in the process, all of them or those `names` names.

    The caches hold what is costly to build and depends on the system, the rule and the
    formulation but not on h: discrete data, step residuals, simulation steps (virtual
    machine or compiled), NLP terms and their derivatives, IPOPT solvers (their journals
    go with them). The next call builds what it needs again, as in a fresh process; use it
    to measure a first solve or to free memory. Compiled libraries on disk stay.

    Parameters
    ----------
    *names : str
        Caches to empty (``"solvers"``, ``"residuals"``, ``"steppers"``, ...; see the
        error for the full list); none: every cache.

    Raises
    ------
    InputError
        A name that is not a cache's.

    Examples
    --------
    >>> import dmoc
    >>> dmoc.clear_caches("solvers")
    >>> dmoc.clear_caches()
    """
    known = cache_names()
    for name in names:
        if name not in known:
            raise InputError(f"`names` must be among {known}; got {name!r}.")
    for cache in list(_ALL):
        if not names or cache.name in names:
            cache.clear()
