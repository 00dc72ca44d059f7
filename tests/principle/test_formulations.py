"""Formulations as values, named layouts and h as an input (docs/theory.md, "Conventions"):
no consumer branches on the variant string, the residual and the compiled step are shared by
every step size and by equal systems, and the caches stay bounded."""

import pathlib
import re

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.formulations import FORMULATIONS, LagrangianMinus, LagrangianPlus, as_formulation
from dmoc._util.layout import Layout
from dmoc.principle import residual
from dmoc.simulation import preparation

PACKAGE = pathlib.Path(dmoc.__file__).parent
COMPARISON = re.compile(r"""variant\s*[!=]=|[!=]=\s*["'][+-]["']|["'][+-]["']\s*[!=]=""")


def test_only_the_formulations_module_compares_variants():
    hits = {str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob("*.py")
            if COMPARISON.search(path.read_text())}
    assert hits <= {"formulations.py"}, hits


def test_the_pattern_finds_a_comparison():
    """Not vacuous: the pattern matches the branches this issue removed."""
    for line in ('if variant == "+":', "plus = traj.variant == '+'", 'if "-" != v:'):
        assert COMPARISON.search(line), line


def test_formulations_are_values():
    assert as_formulation("+") == LagrangianPlus() and as_formulation("-") == LagrangianMinus()
    assert LagrangianPlus() != LagrangianMinus()
    assert hash(LagrangianPlus()) == hash(as_formulation("+"))
    assert as_formulation(FORMULATIONS["-"]) is FORMULATIONS["-"]
    assert (LagrangianPlus().multiplier_node, LagrangianMinus().multiplier_node) == (0, 1)
    with pytest.raises(ValueError, match=r"`variant` must be one of '\+', '-'; got 'plus'"):
        as_formulation("plus")


def test_public_api_accepts_formulation_objects():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    by_name = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=5, variant="-").trajectory
    by_value = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=5,
                             variant=LagrangianMinus()).trajectory
    assert by_value.variant == "-"
    np.testing.assert_array_equal(by_name.p, by_value.p)


def test_residual_is_shared_by_every_step_size():
    system = dmoc.systems.knife_edge(incline=0.3)
    coarse, fine = dmoc.discretize(system, 0.1), dmoc.discretize(system, 0.037)
    for variant in ("+", "-"):
        assert dmoc.step_residual(coarse, variant) is dmoc.step_residual(fine, variant)
        assert dmoc.step_residual(coarse, variant).function is dmoc.step_residual(fine, variant).function
    assert dmoc.step_residual(coarse, "+") is not dmoc.step_residual(coarse, "-")
    other_rule = dmoc.discretize(system, 0.1, "trapezoid")
    assert dmoc.step_residual(other_rule) is not dmoc.step_residual(coarse)


def test_equal_systems_share_the_residual_and_different_ones_do_not():
    a, b = dmoc.systems.knife_edge(mass=2.0), dmoc.systems.knife_edge(mass=2.0)
    assert a is not b and a.key == b.key
    assert dmoc.step_residual(dmoc.discretize(a, 0.1)) is dmoc.step_residual(dmoc.discretize(b, 0.2))
    c = dmoc.systems.knife_edge(mass=3.0)
    assert c.key != a.key
    assert dmoc.step_residual(dmoc.discretize(c, 0.1)) is not dmoc.step_residual(dmoc.discretize(a, 0.1))


def test_simulating_at_another_step_reuses_the_compiled_step():
    system = dmoc.systems.rolling_disk(mass=1.7)
    before = len(preparation._STEPPERS)
    runs = [dmoc.simulate(dmoc.discretize(system, h), q0=[0, 0, 0, 0], v0=[1, 0, 1, 0.5],
                          steps=20).trajectory for h in (0.1, 0.05)]
    assert len(preparation._STEPPERS) in (before + 1, preparation._STEPPERS.maxsize)
    # the second run really used its own h: it covers half the distance in the same steps
    assert runs[1].t[-1] == pytest.approx(runs[0].t[-1] / 2)
    np.testing.assert_allclose(runs[1].q[-1, 3], 0.5 * 1.0, rtol=1e-12)   # phi = phi' t


def test_caches_are_bounded():
    for mass in np.linspace(1.0, 2.0, residual._RESIDUALS.maxsize + 3):
        dmoc.step_residual(dmoc.discretize(dmoc.systems.knife_edge(mass=float(mass)), 0.1))
    assert len(residual._RESIDUALS) == residual._RESIDUALS.maxsize


def test_layout_blocks_round_trip():
    lay = Layout([("q", 3), ("lam", 0), ("u", (2, 2))])
    x = np.arange(lay.size, dtype=float)
    assert lay.size == 7 and lay.numel("lam") == 0
    np.testing.assert_array_equal(lay.unpack(x, "u"), [[3.0, 5.0], [4.0, 6.0]])
    symbolic = lay.split(ca.SX.sym("x", lay.size))
    assert symbolic["lam"].shape == (0, 1) and symbolic["u"].shape == (4, 1)
    joined = ca.Function("j", [], [lay.join({"q": x[:3], "lam": ca.DM(0, 1), "u": x[3:]})])()
    np.testing.assert_array_equal(np.array(joined["o0"]).ravel(), x)
    assert lay.locate(5) == ("u", 0, 1)


def test_residual_rows_and_inputs_are_named():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    R = dmoc.step_residual(disc, "-")
    assert list(R.inputs.blocks) == ["q0", "p0", "q1", "p1", "lam", "s", "u", "h"]
    assert R.function.name_in() == list(R.inputs.blocks)
    rng = np.random.default_rng(0)
    blocks = {k: rng.normal(size=R.inputs.numel(k)) for k in R.inputs.blocks}
    blocks["h"] = 0.1
    by_name = np.array(R(**blocks)).ravel()
    by_position = np.array(R(*blocks.values())).ravel()
    np.testing.assert_array_equal(by_name, by_position)
    assert by_name.shape == (R.row_layout.size,)
