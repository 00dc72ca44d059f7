"""Fixtures shared by the test modules of every stage."""

import pytest

import dmoc
from dmoc.systems import knife_edge


@pytest.fixture(scope="module")
def disc():
    """The knife edge discretized with h = 0.1 (midpoint rule), the system the argument
    checks are written against; a module that defines its own `disc` overrides it."""
    return dmoc.discretize(knife_edge(), 0.1)
