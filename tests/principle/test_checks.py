"""The principle's entry points (action sums, the step residual, the Dirac differential)
refuse unknown variants by name, and the step residual is built once per variant.
Oracle: the messages, checked by content; object identity for the cache."""

import casadi as ca
import pytest

import dmoc


def test_unknown_variants_are_refused(disc):
    with pytest.raises(dmoc.InputError, match=r"`variant` must be one of '\+', '-'; got 'plus'"):
        dmoc.dirac.dirac_differential(disc, "plus")
    symbols = [ca.SX.sym(name, 3, 3) for name in ("q", "q_aux", "p", "s")]
    with pytest.raises(dmoc.InputError, match=r"`variant` must be one of '\+', '-'; got 'x'"):
        dmoc.action_sum(disc, "x", *symbols, 0.1)


def test_step_residual_is_built_once_per_variant(disc):
    assert dmoc.step_residual(disc) is dmoc.step_residual(disc, "+")
    with pytest.raises(ValueError, match="`variant`"):
        dmoc.step_residual(disc, "plus")
