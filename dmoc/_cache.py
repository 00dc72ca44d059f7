"""A bounded cache keyed by value, for the objects that are costly to build (step
residuals, compiled steps, Dirac differentials): least recently used entries are dropped,
so compiled code does not stay alive forever."""

from collections import OrderedDict


class BoundedCache:
    """At most `maxsize` values, built on first use by ``get(key, build)``.

    >>> cache = BoundedCache(1)
    >>> cache.get("a", lambda: 1), cache.get("b", lambda: 2), len(cache)
    (1, 2, 1)
    """

    def __init__(self, maxsize):
        self.maxsize, self._values = maxsize, OrderedDict()

    def get(self, key, build):
        """The value of `key`, built by ``build()`` if it is not held."""
        if key in self._values:
            self._values.move_to_end(key)
            return self._values[key]
        value = self._values[key] = build()
        while len(self._values) > self.maxsize:
            self._values.popitem(last=False)
        return value

    def __len__(self):
        return len(self._values)
