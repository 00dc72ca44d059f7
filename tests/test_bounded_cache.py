"""The bounded caches (`dmoc._util.cache.BoundedCache`) drop the least recently used value:
the builds counted here under an access pattern whose LRU and FIFO victims differ."""

from dmoc._util.cache import BoundedCache, cache_names


def test_a_value_read_again_outlives_one_built_after_it():
    """maxsize 2: build a, build b, read a, build c. Least recently used: b goes (a was read
    after b was built); first in, first out would drop a. Then a is still held (no build)
    and b is built again."""
    built = []

    def build(key):
        return lambda: built.append(key) or key.upper()
    cache = BoundedCache(2, "test-least-recently-used")
    for key in "aba":
        assert cache.get(key, build(key)) == key.upper()
    assert built == ["a", "b"]
    cache.get("c", build("c"))
    assert len(cache) == 2 and built == ["a", "b", "c"]
    assert cache.get("a", build("a")) == "A" and built == ["a", "b", "c"]
    assert cache.get("b", build("b")) == "B" and built == ["a", "b", "c", "b"]
    assert "test-least-recently-used" in cache_names()
