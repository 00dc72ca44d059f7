"""The public boundary: argument errors, Newton failures, Trajectory files, degenerate L.

Oracles, none taken from the code under test:
- error messages are checked by content (the argument they must name);
- Newton failure is provoked where the step equation provably has no real solution: for
  L = v^2/2 and f = v^2 + u the midpoint (+)/(-) step reads h/2 v^2 - v + p_k + h u_k/2 = 0,
  whose discriminant 1 - 2h (p_k + h u_k/2) is computed below step by step (a recursion
  written by hand), so the failing step and the trajectory before it are known exactly;
- save/load must give back every field bit for bit;
- degenerate Lagrangians: L = q0 v1 - q1 v0 - k|q|^2/2 (linear in v) with the discrete flows
  derived by hand (midpoint: the Cayley rotation; trapezoid: Euler start then leapfrog), and
  an LC-circuit-like L with a coordinate without kinetic term, whose other coordinate must
  follow the hand-written midpoint scheme of the reduced oscillator.
"""

from dataclasses import fields

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import diagnostics
from dmoc.systems import knife_edge


@pytest.fixture(scope="module")
def disc():
    return dmoc.discretize(knife_edge(), 0.1)


GOOD = dict(q0=[0.0, 0.0, 0.3], v0=[np.cos(0.3), np.sin(0.3), 1.0], steps=5)


def simulate_with(disc, **changes):
    """simulate() on valid knife-edge data with some arguments replaced (None drops one)."""
    kwargs = {**GOOD, **changes}
    return dmoc.simulate(disc, **{k: v for k, v in kwargs.items() if v is not None})


def test_good_data_runs(disc):
    """The baseline of the error tests below is valid: each test changes one thing."""
    assert simulate_with(disc).success


# ---------------------------------------------------------------------------------------
# simulate(): one bad argument at a time, the error names it


@pytest.mark.parametrize("name, value", [
    ("q0", [0.0, 0.0]),
    ("q0", [[0.0, 0.0, 0.3]]),
    ("q0", [0.0, 0.0, 0.3, 1.0]),
    ("v0", [1.0, 0.0]),
    ("v0", np.zeros((3, 1))),
    ("controls", np.zeros((4, 2))),        # steps = 5
    ("controls", np.zeros((5, 3))),        # n_u = 2
    ("controls", np.zeros(10)),
])
def test_wrong_shapes(disc, name, value):
    with pytest.raises(ValueError, match=f"`{name}`.*shape"):
        simulate_with(disc, **{name: value})


def test_wrong_shape_of_p0(disc):
    with pytest.raises(ValueError, match="`p0`.*shape"):
        simulate_with(disc, v0=None, p0=[1.0, 0.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("name", ["q0", "v0", "p0", "controls"])
def test_non_finite_values(disc, name, bad):
    good = {"q0": GOOD["q0"], "v0": GOOD["v0"], "p0": [1.0, 0.0, 1.0],
            "controls": np.zeros((5, 2))}[name]
    value = np.array(good, dtype=float)
    value.flat[1] = bad
    changes = {name: value}
    if name == "p0":
        changes["v0"] = None
    with pytest.raises(ValueError, match=f"`{name}` must be finite"):
        simulate_with(disc, **changes)


def test_non_numeric_q0(disc):
    with pytest.raises(TypeError, match="`q0`"):
        simulate_with(disc, q0="abc")


@pytest.mark.parametrize("variant", ["x", "plus", None, 1])
def test_unknown_variant(disc, variant):
    with pytest.raises(ValueError, match=r"`variant` must be one of '\+', '-'"):
        dmoc.simulate(disc, **GOOD, variant=variant)
    with pytest.raises(ValueError, match="`variant`"):
        dmoc.StepResidual(disc, variant)


@pytest.mark.parametrize("rule", ["euler", "Midpoint", None, 2])
def test_unknown_rule(rule):
    with pytest.raises(ValueError, match="`rule` must be one of 'midpoint', 'trapezoid'"):
        dmoc.discretize(knife_edge(), 0.1, rule)


def test_both_or_neither_of_v0_p0(disc):
    with pytest.raises(ValueError, match="exactly one of `v0`.*`p0`"):
        simulate_with(disc, p0=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="exactly one of `v0`.*`p0`"):
        simulate_with(disc, v0=None)


@pytest.mark.parametrize("steps", [0, -3, 2.5, 5.0, "5", True])
def test_bad_steps(disc, steps):
    with pytest.raises(ValueError, match="`steps` must be a positive integer"):
        simulate_with(disc, steps=steps)


def test_numpy_integer_steps_accepted(disc):
    assert simulate_with(disc, steps=np.int64(3)).trajectory.steps == 3


@pytest.mark.parametrize("h", [0.0, -0.1, np.nan, np.inf])
def test_bad_step_size(h):
    with pytest.raises(ValueError, match="`h` must be finite and positive"):
        dmoc.discretize(knife_edge(), h)


def test_non_numeric_step_size():
    with pytest.raises(TypeError, match="`h` must be a real number"):
        dmoc.discretize(knife_edge(), "0.1")


@pytest.mark.parametrize("name, value", [("tol", 0.0), ("tol", np.nan), ("max_iter", 0),
                                         ("max_iter", 1.5)])
def test_bad_solver_options(disc, name, value):
    with pytest.raises(ValueError, match=f"`{name}`"):
        simulate_with(disc, **{name: value})


def test_wrong_object_types(disc):
    with pytest.raises(TypeError, match="`disc` must be a Discretization"):
        dmoc.simulate(knife_edge(), **GOOD)
    with pytest.raises(TypeError, match="`system` must be a MechanicalSystem"):
        dmoc.discretize("knife", 0.1)


@pytest.mark.parametrize("v0", [[0.0, 1.0, 0.0], [np.cos(0.3), np.sin(0.3) + 1e-6, 1.0]])
def test_v0_violating_the_constraint(disc, v0):
    """A(q0) v0 != 0: sideways velocity (one of them only 1e-6 off)."""
    with pytest.raises(ValueError, match="`v0` violates the velocity constraints"):
        simulate_with(disc, v0=v0)


# ---------------------------------------------------------------------------------------
# MechanicalSystem: checked on symbols, every problem reported at once


def kinetic(q, v):
    return 0.5 * ca.dot(v, v)


@pytest.mark.parametrize("kwargs, name", [
    (dict(lagrangian=lambda q, v: v), "lagrangian"),                 # a vector
    (dict(lagrangian=lambda q, v: ca.mtimes(v, v.T)), "lagrangian"),  # a matrix
    (dict(lagrangian=3.0), "lagrangian"),                            # not callable
    (dict(lagrangian=lambda q, v: v[7]), "lagrangian"),              # raises inside
    (dict(constraints=lambda q: ca.horzcat(1, 0)), "constraints"),   # 2 columns, n = 3
    (dict(constraints=lambda q: ca.SX.zeros(2, 4)), "constraints"),
    (dict(constraints="A"), "constraints"),
    (dict(force=lambda q, v, u: ca.vertcat(1, 2)), "force"),         # size 2, n = 3
    (dict(force=lambda q, v, u: ca.vertcat(u[0], u[1], 0), n_u=1), "force"),  # u too short
    (dict(force=5), "force"),
    (dict(names=("x", "y")), "names"),
])
def test_mechanical_system_rejects(kwargs, name):
    kwargs = {"lagrangian": kinetic, **kwargs}
    with pytest.raises(ValueError, match=f"`{name}`"):
        dmoc.MechanicalSystem(kwargs.pop("lagrangian"), 3, **kwargs)


def test_mechanical_system_reports_every_problem_at_once():
    with pytest.raises(ValueError) as info:
        dmoc.MechanicalSystem(lambda q, v: v, 3, constraints=lambda q: ca.horzcat(1, 0),
                              force=lambda q, v, u: ca.vertcat(1, 2), names=["a"])
    message = str(info.value)
    for name in ("`lagrangian`", "`constraints`", "`force`", "`names`"):
        assert name in message, message
    assert message.count("\n  - ") == 4


def test_mechanical_system_requires_a_lagrangian():
    """lagrangian=None must be rejected naming it, like any other non-callable."""
    with pytest.raises((TypeError, ValueError), match="`lagrangian`"):
        dmoc.MechanicalSystem(None, 3)


@pytest.mark.parametrize("kwargs, name", [(dict(n=0), "n"), (dict(n=1.5), "n"),
                                          (dict(n=3, n_u=-1), "n_u")])
def test_mechanical_system_sizes(kwargs, name):
    with pytest.raises(ValueError, match=f"`{name}`"):
        dmoc.MechanicalSystem(kinetic, **kwargs)


# ---------------------------------------------------------------------------------------
# Newton failure


@pytest.fixture(scope="module")
def blowup():
    """L = v^2/2 with the force f = v^2 + u: the midpoint step has no real solution once
    1 - 2h (p_k + h u_k/2) < 0."""
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2, 1,
                                   force=lambda q, v, u: v[0] ** 2 + u[0], n_u=1)
    return dmoc.discretize(system, 0.1)


def blowup_by_hand(h, p0, controls):
    """(q, p) up to the first step without a real solution, and that step's index."""
    q, p = [0.0], [p0]
    for k, u in enumerate(controls[:, 0]):
        disc = 1 - 2 * h * (p[-1] + h * u / 2)
        if disc < 0:
            return np.array(q), np.array(p), k
        assert disc > 0.5                    # well-conditioned steps before it
        v = (1 - np.sqrt(disc)) / h          # the root that continues v_0 ~ p_0
        q.append(q[-1] + h * v)
        p.append(v + h / 2 * (v * v + u))
    raise AssertionError("no failing step")


@pytest.mark.parametrize("fail_at", [5, 0])
@pytest.mark.parametrize("variant", ["+", "-"])
def test_newton_failure_raises_and_keeps_the_steps_before(blowup, variant, fail_at):
    controls = np.zeros((10, 1))
    controls[fail_at] = 100.0                # discriminant < 0 at that step
    q, p, k = blowup_by_hand(0.1, 1.0, controls)
    assert k == fail_at
    with pytest.raises(dmoc.SolverError, match=rf"at step {k} \(t = {k * 0.1:g}\)") as info:
        dmoc.simulate(blowup, q0=[0.0], v0=[1.0], steps=10, controls=controls, variant=variant)
    result = info.value.result
    assert isinstance(info.value, dmoc.DmocError)
    assert result.success is False and result.status == "newton_failed"
    assert result.stats["completed_steps"] == k == result.trajectory.steps
    assert result.stats["steps"] == 10
    traj = result.trajectory
    np.testing.assert_allclose(traj.q.ravel(), q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.p.ravel(), p, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(traj.u, controls[:k])
    if k:
        assert diagnostics.residual_norms(blowup, traj).max() < 1e-10
    # throw=False: the same result, returned.
    quiet = dmoc.simulate(blowup, q0=[0.0], v0=[1.0], steps=10, controls=controls,
                          variant=variant, throw=False)
    assert quiet.success is False and quiet.status == result.status
    assert quiet.message == result.message == str(info.value)
    assert {k_: v for k_, v in quiet.stats.items() if k_ != "wall_time"} == \
        {k_: v for k_, v in result.stats.items() if k_ != "wall_time"}
    for f in fields(traj):
        assert np.array_equal(getattr(quiet.trajectory, f.name), getattr(traj, f.name)), f.name


# ---------------------------------------------------------------------------------------
# Trajectory save/load


def assert_same_trajectory(a, b):
    for f in fields(dmoc.Trajectory):
        x, y = getattr(a, f.name), getattr(b, f.name)
        assert type(x) is type(y), f.name
        assert np.array_equal(x, y), f.name
        assert np.asarray(x).shape == np.asarray(y).shape, f.name


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("with_constraints", [True, False])
def test_trajectory_round_trip(tmp_path, variant, with_constraints):
    rng = np.random.default_rng(5)
    if with_constraints:               # m = 1, n_u = 2, random controls
        d, kw = dmoc.discretize(knife_edge(incline=0.2), 0.07), dict(
            q0=GOOD["q0"], v0=GOOD["v0"], controls=rng.normal(size=(12, 2)))
    else:                              # m = 0, n_u = 0: empty lam, u, mu
        d = dmoc.discretize(dmoc.MechanicalSystem(
            lambda q, v: 0.5 * ca.dot(v, v) + ca.cos(q[0]), 2), 0.07)
        kw = dict(q0=[0.3, 0.1], v0=[0.2, -0.4])
    traj = dmoc.simulate(d, steps=12, variant=variant, **kw).trajectory
    path = tmp_path / "traj.npz"
    traj.save(path)
    back = dmoc.Trajectory.load(path)
    assert_same_trajectory(traj, back)
    assert back.steps == 12 and back.variant == variant


def test_trajectory_round_trip_path_without_suffix(tmp_path):
    """save(path) then load(path) with the same path must round-trip; np.savez appends
    ".npz" to a path without that suffix, so save must write (or load read) that file."""
    d = dmoc.discretize(knife_edge(), 0.1)
    traj = dmoc.simulate(d, **GOOD).trajectory
    traj.save(tmp_path / "run")
    assert_same_trajectory(traj, dmoc.Trajectory.load(tmp_path / "run"))


# ---------------------------------------------------------------------------------------
# Degenerate Lagrangians: accepted, dL/dv never inverted

K_ROT = 1.7


def rotation_system():
    """L = q0 v1 - q1 v0 - K |q|^2/2: linear in v; its flow is a rotation at rate K/2."""
    return dmoc.MechanicalSystem(
        lambda q, v: q[0] * v[1] - q[1] * v[0] - K_ROT / 2 * (q[0] ** 2 + q[1] ** 2), 2)


def rotate(q, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * q[0] - s * q[1], s * q[0] + c * q[1]])


@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
@pytest.mark.parametrize("variant", ["+", "-"])
def test_lagrangian_linear_in_velocity(variant, rule):
    """p = dL/dv = (-q1, q0) whatever v is. By hand, the midpoint rows give
    q_{k+1} - q_k = (hK/2) J (q_k + q_{k+1})/2, J q = (-q1, q0): the Cayley rotation by
    2 atan(hK/4) per step. The trapezoid rows give an Euler first step and then the
    leapfrog q_{k+1} = q_{k-1} + hK J q_k."""
    h, N, q0 = 0.1, 50, np.array([1.0, 0.5])
    d = dmoc.discretize(rotation_system(), h, rule)
    res = dmoc.simulate(d, q0=q0, v0=[0.0, 0.0], steps=N, variant=variant)
    assert res.success
    if rule == "midpoint":
        want = rotate(q0, 2 * np.arctan(h * K_ROT / 4) * np.arange(N + 1))
    else:
        J = lambda q: np.array([-q[1], q[0]])  # noqa: E731
        want = [q0, q0 + h * K_ROT / 2 * J(q0)]
        for _ in range(N - 1):
            want.append(want[-2] + h * K_ROT * J(want[-1]))
    np.testing.assert_allclose(res.trajectory.q, np.array(want), rtol=0, atol=1e-12)
    # Starting from the momentum instead gives the same motion.
    again = dmoc.simulate(d, q0=q0, p0=[-q0[1], q0[0]], steps=N, variant=variant)
    np.testing.assert_allclose(again.trajectory.q, res.trajectory.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("variant", ["+", "-"])
def test_lc_circuit_like_lagrangian(variant):
    """L = v0^2/2 - k (q0 - q1)^2/2 - c q1^2/2: q1 has no kinetic term. Its midpoint row
    forces (q1 mean) = k/(k+c) (q0 mean), and q0 then follows the midpoint scheme of the
    oscillator with k_eff = k c/(k + c), written here by hand; p1 stays 0."""
    k, c, h, N = 2.0, 3.0, 0.1, 50
    system = dmoc.MechanicalSystem(
        lambda q, v: 0.5 * v[0] ** 2 - k / 2 * (q[0] - q[1]) ** 2 - c / 2 * q[1] ** 2, 2)
    res = dmoc.simulate(dmoc.discretize(system, h), q0=[1.0, 0.3], v0=[0.4, 0.0],
                        steps=N, variant=variant)
    q = res.trajectory.q
    k_eff, x, p = k * c / (k + c), [1.0], 0.4
    for _ in range(N):
        x1 = (p + x[-1] * (1 / h - h * k_eff / 4)) / (1 / h + h * k_eff / 4)
        p = (x1 - x[-1]) / h - h / 2 * k_eff * (x1 + x[-1]) / 2
        x.append(x1)
    np.testing.assert_allclose(q[:, 0], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose((q[1:, 1] + q[:-1, 1]) / 2, k / (k + c) * (q[1:, 0] + q[:-1, 0]) / 2,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.trajectory.p[:, 1], 0.0, rtol=0, atol=1e-12)
    assert np.ptp(q[:, 0]) > 0.5                     # it oscillates


def test_mechanical_system_rejects_undeclared_symbols():
    stray = ca.SX.sym("stray")
    with pytest.raises(ValueError, match=r"`lagrangian` uses symbols .*stray") as info:
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) + stray * q[0], 2,
                              force=lambda q, v, u: ca.vertcat(stray, 0))
    assert "`force` uses symbols" in str(info.value)     # every problem, at once


def test_mechanical_system_rejects_dependent_constraint_rows():
    with pytest.raises(ValueError, match=r"`constraints` must have linearly independent rows"):
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 3,
                              constraints=lambda q: ca.vertcat(ca.horzcat(1, 0, q[0]),
                                                               ca.horzcat(2, 0, 2 * q[0])))
