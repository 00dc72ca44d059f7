"""Degenerate Lagrangians with the stage rules and the trapezoid (docs/degenerate.md).

Oracles, none taken from the code under test:
- DOP853 (scipy) on the continuous equations derived here: for L = a(q).v - V(q) the
  Euler-Lagrange equations are (Da^T - Da) qdot = grad V; for the point vortices the
  Biot-Savart law (a pair and three vortices). The measured log-log slope must equal
  `Discretization.order`.
- The flow's own invariants, written here: for L = a(q).v - V(q) the energy
  v.dL/dv - L = V(q) is conserved, so with V = |q|^2/2 the radius |q| is; a vortex pair
  keeps its distance. A growing alternating mode shows as their error growing over a long
  run (the trapezoid), a bounded one as an error that stays at its first value (midpoint).
"""

import warnings

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc._util.cache import BoundedCache
from dmoc.discrete import QuadratureRule
from dmoc.errors import OrderReductionWarning, ParasiticModeWarning
from dmoc.principle import parasitic
from dmoc.systems import knife_edge, lc_circuit, point_vortices

PAIR = (1.0, 2.0)
PAIR_Q0 = np.array([1.0, 0.0, -0.5, 0.3])
FORM_Q0 = np.array([1.0, 0.2])


def one_form(q):
    """a(q) = (-y/2, x/2 + x^3/3): dA = (1 + x^2) dx ^ dy, nonlinear in q."""
    return np.array([-q[1] / 2, q[0] / 2 + q[0] ** 3 / 3])


def one_form_system(quartic=True):
    """L = a(q).v - V(q), V = |q|^2/2 + x^4/4 (without the quartic term: V = |q|^2/2)."""
    return dmoc.MechanicalSystem(
        lambda q, v: -q[1] / 2 * v[0] + (q[0] / 2 + q[0] ** 3 / 3) * v[1]
        - (q[0] ** 2 + q[1] ** 2) / 2 - quartic * q[0] ** 4 / 4, 2)


def one_form_flow(q):
    """(Da^T - Da) qdot = grad V with Da = [[0, -1/2], [1/2 + x^2, 0]]:
    Da^T - Da = (1 + x^2) [[0, 1], [-1, 0]], so xdot = -V_y/(1 + x^2), ydot = V_x/(1 + x^2)."""
    x, y = q
    return np.array([-y, x + x ** 3]) / (1 + x * x)


def vortex_form(gamma):
    """a(q) = (Gamma_i/2 (-y_i, x_i))_i of the point vortices."""
    return lambda q: np.concatenate([[-g * q[2 * i + 1] / 2, g * q[2 * i] / 2] for i, g in enumerate(gamma)])


def biot_savart(gamma):
    """rdot_i = sum_{j != i} Gamma_j/(2 pi) J (r_i - r_j)/|r_i - r_j|^2, J the rotation by +90 deg."""
    def flow(q):
        r, v = q.reshape(-1, 2), np.zeros((len(gamma), 2))
        for i in range(len(gamma)):
            for j in range(len(gamma)):
                if i != j:
                    dx, dy = r[i] - r[j]
                    v[i] += gamma[j] / (2 * np.pi) * np.array([-dy, dx]) / (dx * dx + dy * dy)
        return v.ravel()
    return flow


pair_form = vortex_form(PAIR)
THREE = (1.0, 2.0, -0.7)


CASES = {"vortex pair": (lambda: point_vortices(PAIR), biot_savart(PAIR), pair_form, PAIR_Q0,
                         (8, 16, 32, 64), 4.0),
         "three vortices": (lambda: point_vortices(THREE), biot_savart(THREE), vortex_form(THREE),
                            np.array([1.0, 0.0, -0.5, 0.3, 0.2, -1.0]), (8, 16, 32), 2.0),
         "one-form": (one_form_system, one_form_flow, one_form, FORM_Q0, (20, 40, 80, 160), 4.0)}


def quiet_discretize(system, h, rule):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OrderReductionWarning)
        return dmoc.discretize(system, h, rule)


@pytest.mark.parametrize("rule", ["midpoint", "lobatto3", "lobatto4"])
@pytest.mark.parametrize("case", CASES)
def test_measured_order_is_the_declared_order(case, rule):
    make, flow, form, q0, steps, T = CASES[case]
    system = make()
    exact = solve_ivp(lambda t, q: flow(q), (0.0, T), q0, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    errors, declared = [], set()
    for N in steps:
        disc = quiet_discretize(system, T / N, rule)
        declared.add(disc.order)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ParasiticModeWarning)     # lobatto3 on three vortices
            q = dmoc.simulate(disc, q0=q0, p0=form(q0), steps=N).trajectory.q
        errors.append(np.abs(q[-1] - exact).max())
    order, = declared
    assert min(errors) > 1e-11, errors                       # above the round-off floor
    slope = np.polyfit(np.log(np.array(steps, float)), -np.log(errors), 1)[0]
    assert abs(slope - order) < 0.35, (errors, slope, order)


@pytest.mark.parametrize("rule, order, kept", [("lobatto3", 4, 2), ("lobatto4", 6, 4)])
@pytest.mark.parametrize("case", CASES)
def test_discretize_warns_where_a_stage_rule_loses_order(case, rule, order, kept):
    with pytest.warns(OrderReductionWarning, match=f"`rule` '{rule}' has order {kept}, not {order}"):
        disc = dmoc.discretize(CASES[case][0](), 0.1, rule)
    assert (disc.order, disc.rule.order) == (kept, order)


def pendulum():
    return dmoc.MechanicalSystem(lambda q, v: v[0] ** 2 / 2 + ca.cos(q[0]), 1)


@pytest.mark.parametrize("rule", list(dmoc.discrete.RULES))
@pytest.mark.parametrize("make", [knife_edge, pendulum], ids=["knife edge", "pendulum"])
def test_regular_lagrangians_keep_their_order_and_never_warn(make, rule):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        disc = dmoc.discretize(make(), 0.1, rule)
        dmoc.step_residual(disc)
    assert disc.order == disc.rule.order


@pytest.mark.parametrize("rule, steps", [("lobatto3", (20, 40, 80)), ("lobatto4", (10, 20, 40))])
def test_a_massless_coordinate_tied_by_a_constraint_keeps_the_order(rule, steps):
    """q = (x, phi), L = xdot^2/2 + cos x, phidot = xdot (a massless wheel rolling with x):
    d^2L/dv^2 is singular, but not on ker A, and the motion is the pendulum's,
    x'' = -sin x (DOP853), phi = x - x_0. No warning; the rule's order is declared and met."""
    system = dmoc.MechanicalSystem(lambda q, v: v[0] ** 2 / 2 + ca.cos(q[0]), 2,
                                   constraints=lambda q: ca.horzcat(1, -1))
    T, x0, w0 = 4.0, 1.0, 0.3
    x = solve_ivp(lambda t, z: [z[1], -np.sin(z[0])], (0.0, T), [x0, w0], method="DOP853",
                  rtol=1e-13, atol=1e-13).y[0, -1]
    errors = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for N in steps:
            disc = dmoc.discretize(system, T / N, rule)
            q = dmoc.simulate(disc, q0=[x0, 0.0], v0=[w0, w0], steps=N).trajectory.q
            errors.append(np.abs(q[-1] - [x, x - x0]).max())
    assert disc.order == disc.rule.order
    slope = np.polyfit(np.log(np.array(steps, float)), -np.log(errors), 1)[0]
    assert abs(slope - disc.order) < 0.35, (errors, slope)


@pytest.mark.parametrize("unit", [1e-7, 1.0, 1e7])
def test_degeneracy_does_not_depend_on_the_units_of_a_coordinate(unit):
    """Measuring q_1 in another unit (q_1 -> unit q_1) scales row and column 1 of
    d^2L/dv^2 by `unit`, which keeps it singular or not. L = v_0^2/2 + unit^2 v_1^2/2
    + cos q_0 has d^2L/dv^2 = diag(1, unit^2), positive definite: regular, the order of the
    rule kept and no warning, at unit = 1e-7 and 1e7 too (a relative tolerance of 1e-10
    on d^2L/dv^2 called both degenerate). The LC circuit with its capacitor charges in that
    unit, L = L_0/2 v_L^2 - (unit q_1)^2/(2 C_1) - (unit q_2)^2/(2 C_2), A = [1, -unit,
    -unit], has d^2L/dv^2 = diag(L_0, 0, 0), of rank 1 on the 2-dimensional ker A:
    degenerate at every unit (lobatto3 keeps order 2, with the warning)."""
    regular = dmoc.MechanicalSystem(lambda q, v: v[0] ** 2 / 2 + (unit * v[1]) ** 2 / 2 + ca.cos(q[0]), 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        disc = dmoc.discretize(regular, 0.1, "lobatto3")
        dmoc.step_residual(disc)
    assert disc.order == disc.rule.order == 4
    circuit = dmoc.MechanicalSystem(
        lambda q, v: 0.8 / 2 * v[0] ** 2 - (unit * q[1]) ** 2 / (2 * 0.5) - (unit * q[2]) ** 2 / (2 * 1.5),
        3, constraints=lambda q: ca.horzcat(1, -unit, -unit))
    with pytest.warns(OrderReductionWarning, match="has order 2, not 4"):
        assert dmoc.discretize(circuit, 0.1, "lobatto3").order == 2


def test_a_hamiltonian_discretization_declares_its_rule_order():
    system = dmoc.HamiltonianSystem(lambda q, p: p[0] ** 2 / 2 - ca.cos(q[0]), 1)
    assert dmoc.discretize(system, 0.1, "symplectic-euler").order == 1


def test_degenerate_order_above_the_order_is_refused():
    with pytest.raises(ValueError, match="`degenerate_order` must not exceed `order` \\(2\\)"):
        QuadratureRule("x", 2, (0.0, 1.0), ((0.5, 1.0),), degenerate_order=4)


def radius_error(rule, steps, p_offset=0.0):
    """max | |q_k| - |q_0| | over the first and the last quarter of a run at h = 0.1 on
    L = a(q).v - |q|^2/2, whose energy V = |q|^2/2 the flow conserves."""
    system = one_form_system(quartic=False)
    q0 = np.array([1.0, 0.7])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParasiticModeWarning)
        q = dmoc.simulate(quiet_discretize(system, 0.1, rule), q0=q0, p0=one_form(q0) + p_offset,
                          steps=steps).trajectory.q
    error = np.abs(np.hypot(q[:, 0], q[:, 1]) - np.hypot(*q0))
    return error[:steps // 4].max(), error[-steps // 4:].max()


def test_the_trapezoid_on_a_nonlinear_one_form_warns_and_its_error_grows():
    with pytest.warns(ParasiticModeWarning, match="`rule` 'trapezoid'.*rule='midpoint'"):
        dmoc.step_residual(dmoc.discretize(one_form_system(quartic=False), 0.1, "trapezoid"))
    first, last = radius_error("trapezoid", 6000)
    assert last > 0.1 and last > 3 * first, (first, last)          # linear growth: about 4
    first, last = radius_error("midpoint", 6000)
    assert last < 1e-3 and last < 1.01 * first, (first, last)


def test_the_trapezoid_on_the_vortex_pair_warns_and_an_excited_start_diverges():
    """The pair keeps its distance; from p_0 = a(q_0) + 0.01 the trapezoid loses it while
    the midpoint keeps it to the offset's size."""
    system = point_vortices(PAIR)
    with pytest.warns(ParasiticModeWarning, match="`rule` 'trapezoid'"):
        dmoc.step_residual(dmoc.discretize(system, 0.1, "trapezoid"))
    distance = {}
    for rule in ("trapezoid", "midpoint"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ParasiticModeWarning)
            q = dmoc.simulate(dmoc.discretize(system, 0.1, rule), q0=PAIR_Q0, p0=pair_form(PAIR_Q0) + 0.01,
                              steps=5000).trajectory.q
        d = np.hypot(q[:, 0] - q[:, 2], q[:, 1] - q[:, 3])
        distance[rule] = np.abs(d - np.hypot(*(PAIR_Q0[:2] - PAIR_Q0[2:]))).max()
    assert distance["trapezoid"] > 0.5 and distance["midpoint"] < 0.02, distance


def rotation():
    """L = q0 v1 - q1 v0 - |q|^2: linear, so the trapezoid is the leapfrog on a linear
    oscillator, whose parasitic root stays on the unit circle (|hK| < 1)."""
    return dmoc.MechanicalSystem(lambda q, v: q[0] * v[1] - q[1] * v[0] - ca.dot(q, q), 2)


@pytest.mark.parametrize("make, rule", [
    (one_form_system, "midpoint"), (one_form_system, "lobatto4"), (lambda: point_vortices(PAIR), "midpoint"),
    (lambda: point_vortices(PAIR), "lobatto4"), (lambda: lc_circuit(0.8, (0.5, 1.5)), "midpoint"),
    (rotation, "trapezoid")],
    ids=["one-form midpoint", "one-form lobatto4", "pair midpoint", "pair lobatto4", "LC midpoint",
         "linear trapezoid"])
def test_bounded_alternating_modes_do_not_warn(make, rule):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OrderReductionWarning)
        warnings.simplefilter("error", ParasiticModeWarning)
        dmoc.step_residual(dmoc.discretize(make(), 0.1, rule))


@pytest.mark.parametrize("rule", ["midpoint", "trapezoid", "lobatto3", "lobatto4"])
def test_the_advice_of_the_warning_is_never_the_rule_in_use(monkeypatch, rule):
    """With the growth made 19 (the measurement replaced: the advice is under test), the
    warning under each rule names another rule to use, never the one in use."""
    monkeypatch.setattr(parasitic, "_GROWTH", BoundedCache(4, "test_alternating_growth"))
    monkeypatch.setattr(parasitic, "alternating_growth", lambda R, system, h: 19.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("ignore", OrderReductionWarning)
        warnings.simplefilter("always", ParasiticModeWarning)
        dmoc.step_residual(dmoc.discretize(one_form_system(), 0.1, rule))
    message, = (str(w.message) for w in caught if w.category is ParasiticModeWarning)
    assert f"`rule` {rule!r}" in message and "grew 19-fold" in message, message
    advised = {name for name in dmoc.discrete.RULES if f"rule={name!r}" in message}
    assert advised and rule not in advised, message


def test_the_growth_is_measured_at_each_step_h(monkeypatch):
    """The test's motion depends on h (its rate is measured at h, its step is at most
    40 h): a discretization at another h is measured again, the same h is not."""
    measured = []
    monkeypatch.setattr(parasitic, "_GROWTH", BoundedCache(4, "test_alternating_growth"))
    monkeypatch.setattr(parasitic, "alternating_growth", lambda R, system, h: measured.append(h) or 1.0)
    for h in (0.1, 0.05, 0.1):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OrderReductionWarning)
            dmoc.step_residual(dmoc.discretize(one_form_system(), h, "midpoint"))
    assert measured == [0.1, 0.05]


def test_lobatto4_on_a_nonlinear_one_form_stays_bounded():
    """The check's verdict on lobatto4 (no warning above), against a long run."""
    first, last = radius_error("lobatto4", 6000, p_offset=0.01)
    assert last < 1.05 * first, (first, last)
