"""Reliability defects whose fix lives in the core (stepper, simulate, ocp, optimize,
system): each test states the behaviour issue 16 asks for and is marked
``xfail(strict=True)`` with the file the fix belongs in, so it fails the moment the defect
is fixed and its marker must then be removed (docs/verification.md, "Bad inputs").

Oracles, none taken from the code under test: a force sqrt(u) that is NaN exactly at the
step whose control is negative; the knife edge's invariance under translation (its L and
A(q) depend on theta only) and under scaling of mass and inertia together (the motion
does not change); messages by content.
"""

import os
import tempfile

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import diagnostics
from dmoc.systems import knife_edge


def xfail(where, what):
    return pytest.mark.xfail(strict=True, reason=f"fix in {where}: {what}")


@pytest.fixture(scope="module")
def disc():
    return dmoc.discretize(knife_edge(), 0.1)


def problem(disc, **kwargs):
    return dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 0.1, 0], **kwargs)


# ---------------------------------------------------------------------------------------
# simulate: NaN at the step where it appears, never success


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


# ---------------------------------------------------------------------------------------
# Tolerances that follow the scale of the data


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


def test_optimum_is_translation_invariant():
    disc = dmoc.discretize(knife_edge(), 0.04)
    shift = np.array([1e6, 1e6, 0.0])
    results = [dmoc.optimize(dmoc.OptimalControlProblem(disc, 20, q_start=d, q_goal=d + [0, 1, 0]),
                             throw=False) for d in (np.zeros(3), shift)]
    assert results[1].success, results[1].message
    assert results[1].cost == pytest.approx(results[0].cost, rel=1e-6)


# ---------------------------------------------------------------------------------------
# optimize: options and solver messages


@pytest.mark.parametrize("options, error, words", [
    ({"max_iter": None}, TypeError, r"`options\['max_iter'\]`"),
    ({3: 1}, TypeError, "string keys"),
])
def test_options_of_the_wrong_kind_are_named(disc, options, error, words):
    with pytest.raises(error, match=words):
        dmoc.optimize(problem(disc), options=options)


@pytest.mark.parametrize("options, name", [({"max_iter": "many"}, "max_iter"),
                                           ({"mu_strategy": "nonsense"}, "mu_strategy")])
def test_rejected_option_is_named_on_the_first_line(disc, options, name, capfd):
    with pytest.raises(ValueError) as info:
        dmoc.optimize(problem(disc), options=options)
    capfd.readouterr()
    assert name in str(info.value).splitlines()[0]


def test_invalid_option_at_solve_time_reports_this_solve(disc, capfd):
    dmoc.optimize(problem(disc), options={"max_iter": 3}, throw=False)
    result = dmoc.optimize(problem(disc), options={"linear_solver": "ma57"}, throw=False)
    capfd.readouterr()
    assert result.status == "Invalid_Option"
    assert result.stats["iterations"] == 0 and "after 3 iterations" not in result.message


def test_invalid_number_names_the_non_finite_value(capfd):
    """A cost that is NaN at the start point (log of a negative number)."""
    result = dmoc.optimize(dmoc.OptimalControlProblem(
        dmoc.discretize(knife_edge(), 0.1), 5, q_start=[0, 0, 0], q_goal=[0, 0.1, 0],
        running_cost=lambda q, v, u: ca.sumsqr(u) + ca.log(q[0] - 1)), throw=False)
    capfd.readouterr()
    assert result.status == "Invalid_Number_Detected"
    assert "0.00e+00" not in result.message and ("NaN" in result.message or "Inf" in result.message)


def test_absurd_step_fails_naming_the_violation(capfd):
    """h = 1e-302: 1/h is finite but the rows are of order 1e300; IPOPT stops and the
    message names the most violated group and its size."""
    tiny = dmoc.discretize(knife_edge(), 1e-302)
    result = dmoc.optimize(dmoc.OptimalControlProblem(tiny, 5, q_start=[0, 0, 0],
                                                      q_goal=[0, 0.1, 0]), throw=False)
    capfd.readouterr()
    assert not result.success
    assert "most violated" in result.message and "e+30" in result.message


@pytest.mark.parametrize("bounds", [([np.inf] * 2, [np.inf] * 2), ([-np.inf] * 2, [-np.inf] * 2)])
def test_infinite_bounds_on_the_wrong_side(disc, bounds):
    with pytest.raises(ValueError, match="`control_bounds`"):
        problem(disc, control_bounds=bounds)


# ---------------------------------------------------------------------------------------
# Inputs that reach CasADi or numpy unchecked


def test_ragged_controls_with_lobatto():
    disc = dmoc.discretize(knife_edge(), 0.1, "lobatto3")
    with pytest.raises(dmoc.InputError, match="`controls`.*ragged"):
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=3, controls=[[0, 0], [0], [0, 0]])


def test_names_of_the_wrong_kind():
    with pytest.raises((TypeError, ValueError), match="`names`"):
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 2, names=5)


def test_lagrangian_without_velocities():
    """Refused where it is given (before, it 'simulated' q = 0.1, 9.3, 18.9, ...)."""
    with pytest.raises(ValueError, match="`lagrangian` must depend on the velocities"):
        system = dmoc.MechanicalSystem(lambda q, v: ca.sin(q[0]), 1)
        dmoc.simulate(dmoc.discretize(system, 0.1), q0=[0.1], v0=[0.0], steps=3)


def test_jit_without_a_usable_working_directory():
    here = os.getcwd()
    gone = tempfile.mkdtemp()
    os.chdir(gone)
    os.rmdir(gone)
    try:
        result = dmoc.simulate(dmoc.discretize(knife_edge(mass=1.9), 0.1), q0=[0, 0, 0],
                               v0=[1, 0, 1], steps=3, jit=True)
    finally:
        os.chdir(here)
    assert result.success
