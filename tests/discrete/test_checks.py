"""Rules and discretizations check their data: an empty quadrature rule and a
Discretization built directly with a bad step or an unknown rule are refused, naming the
argument. Oracle: the messages, checked by content."""

import pytest

import dmoc
from dmoc.discrete.quadrature_rules import QuadratureRule


def test_empty_quadrature_rule_is_refused():
    with pytest.raises(ValueError, match="`points` must be"):
        QuadratureRule("empty", 2)


def test_discretization_validates_when_built_directly():
    with pytest.raises(ValueError, match="`h`"):
        dmoc.Discretization(dmoc.systems.knife_edge(), -0.1)
    with pytest.raises(ValueError, match="`rule`"):
        dmoc.Discretization(dmoc.systems.knife_edge(), 0.1, "simpson")
