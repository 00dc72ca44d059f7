"""Which steps the simulator accepts: a step that fails (Newton without a real solution, a
NaN force, a NaN constraint row, a force non-finite at the end node only) ends the run at
that step with the steps before kept, never as success; converged steps are accepted at
any scale of the data (tiny momenta, huge masses, large legitimate forces).

Oracles, none taken from the code under test:
- Newton failure is provoked where the step equation provably has no real solution: for
  L = v^2/2 and f = v^2 + u the midpoint (+)/(-) step reads h/2 v^2 - v + p_k + h u_k/2 = 0,
  with no real root once 1 - 2h(p_k + h u_k/2) < 0 (the steps before it are solved by
  hand), so the failing step and the trajectory before it are known exactly;
- a force sqrt(u) that is NaN exactly at the step whose control is negative, and rows made
  NaN beyond a known coordinate;
- the knife edge's invariance under scaling of mass and inertia together (the motion does
  not change)."""

from dataclasses import fields

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import diagnostics
from dmoc.systems import knife_edge


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


def sqrt_force():
    """L = v^2/2 with the force sqrt(u): NaN exactly at a step whose control is < 0."""
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2, 1,
                                   force=lambda q, v, u: ca.sqrt(u[0]), n_u=1)
    return dmoc.discretize(system, 0.1)


@pytest.mark.parametrize("k", [9, 4])
def test_nan_force_fails_at_its_own_step(k):
    controls = np.ones((10, 1))
    controls[k] = -1.0
    result = dmoc.simulate(sqrt_force(), q0=[0.0], v0=[1.0], steps=10, controls=controls,
                           throw=False)
    assert result.success is False
    assert result.stats["completed_steps"] == k == result.trajectory.steps
    assert np.isfinite(result.trajectory.q).all() and np.isfinite(result.trajectory.p).all()
    assert f"step {k}" in result.message and "NaN" in result.message


@pytest.mark.parametrize("variant", ["+", "-"])
def test_a_nan_constraint_row_fails_the_step_though_the_state_stays_finite(variant):
    """A holonomic row that turns NaN (sqrt of a negative number, scaled by 1e-300 so the
    motion itself does not feel it) while q, p and the outputs stay finite: the step is
    not converged, whatever the residual's max-norm says (CasADi's norm skips NaN). The
    step counts the non-finite entries of its rows too."""
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 2,
                                   holonomic=lambda q: q[0] - 1 + 1e-300 * ca.sqrt(q[1] + 10))
    result = dmoc.simulate(dmoc.discretize(system, 0.01), q0=[1.0, -9.945], v0=[0.0, -1.0],
                           steps=20, variant=variant, throw=False)
    assert result.success is False and result.status == "non_finite"
    completed = result.stats["completed_steps"]
    assert completed == 5                    # y passes -10 during step 5 (y_k = -9.945 - 0.01 k)
    assert all(np.isfinite(float(system.holonomic(q))) for q in result.trajectory.q)


def test_a_force_non_finite_at_the_end_node_only_fails_the_last_step():
    """The trapezoid's f_d^+ = h/2 f(q_{k+1}): a force that is NaN beyond q = -10 makes only
    p_{k+1} of the step that crosses it NaN (its rows and q_{k+1} stay finite), and that
    step fails instead of ending the run with p_N = NaN."""
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 1,
                                   force=lambda q, v, u: 1e-300 * ca.sqrt(q[0] + 10))
    result = dmoc.simulate(dmoc.discretize(system, 0.01, "trapezoid"), q0=[-9.955], v0=[-1.0],
                           steps=5, throw=False)
    assert result.success is False and result.status == "non_finite"
    assert result.stats["completed_steps"] == 4
    assert np.isfinite(result.trajectory.p).all()


def test_tiny_momenta_are_judged_against_one_not_against_themselves():
    """The acceptance scale is 1 + max |p|: with m = J = 1e-12 the momenta are about 1e-6
    while the constraint rows are of the size of the motion; a scale of max |p| alone
    would demand residuals of 1e-18 and fail converged steps."""
    disc = dmoc.discretize(knife_edge(mass=1e-12, inertia=1e-12), 0.01)
    result = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1e6, 0, 1e3], steps=200, throw=False)
    assert result.success, result.message
    assert result.stats["completed_steps"] == 200


@pytest.mark.parametrize("scale", [1e8])
def test_mass_scale_does_not_change_the_motion(scale):
    q0, v0 = [0, 0, 0.3], [np.cos(0.3), np.sin(0.3), 1.0]
    runs = [dmoc.simulate(dmoc.discretize(knife_edge(mass=s, inertia=s, incline=0.0), 0.1),
                          q0=q0, v0=v0, steps=20, throw=False) for s in (1.0, scale)]
    assert runs[1].success, runs[1].message
    np.testing.assert_allclose(runs[1].trajectory.q, runs[0].trajectory.q, rtol=0, atol=1e-10)


def test_large_legitimate_forces_converge(disc):
    result = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=20,
                           controls=np.full((20, 2), 1e7), throw=False)
    assert result.success, result.message
    # the constraint rows are velocities, here ~1e7: round-off relative to that size
    speed = np.abs(result.trajectory.velocities).max()
    assert speed > 1e6
    assert diagnostics.constraint_violation(disc, result.trajectory).max() < 1e-10 * speed
