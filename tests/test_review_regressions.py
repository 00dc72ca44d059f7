"""Regressions for mistakes found in review: arguments are named when wrong, sizes are
checked where CasADi would silently read empty inputs as zeros, and nothing is lost or
aliased between results."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import diagnostics
from dmoc.dirac import dirac_defect
from dmoc.optimize import initial_guess
from dmoc.problems import knife_edge_parking


@pytest.fixture(scope="module")
def knife():
    return dmoc.discretize(dmoc.systems.knife_edge(), 0.1)


@pytest.mark.parametrize("field, value", [("lam", np.zeros((2, 1))), ("u", np.zeros((2, 2))),
                                          ("s", np.zeros((4, 1)))])
def test_trajectory_names_misshaped_fields(field, value):
    data = dict(t=np.arange(4.0), q=np.zeros((4, 3)), p=np.zeros((4, 3)), lam=np.zeros((3, 1)),
                u=np.zeros((3, 2)), h=1.0, variant="+")
    data[field] = value
    with pytest.raises(ValueError, match=f"`{field}`"):
        dmoc.Trajectory(**data)


def test_trajectory_rejects_bad_step():
    with pytest.raises(ValueError, match="`h`"):
        dmoc.Trajectory([0, 1], [[0.0], [1.0]], [[0.0], [0.0]], [], [], -1.0, "+")


def test_trajectory_owns_its_arrays():
    result = dmoc.optimize(knife_edge_parking(20))
    before = result.x.copy()
    result.trajectory.q[:] = 7.0
    assert np.array_equal(result.x, before)


def test_diagnostics_check_every_size(knife):
    free = dmoc.Trajectory(0.1 * np.arange(3.0), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((2, 0)),
                           np.zeros((2, 2)), 0.1, "+")
    for check in (diagnostics.residual_norms, diagnostics.constraint_violation, dirac_defect):
        with pytest.raises(ValueError, match=r"`traj.lam`"):
            check(knife, free)


def test_zero_step_trajectory_diagnostics(knife):
    empty = dmoc.Trajectory([0.0], [[0, 0, 0]], [[1, 0, 0]], np.zeros((0, 1)), np.zeros((0, 2)),
                            0.1, "+")
    for check in (diagnostics.energy, diagnostics.residual_norms,
                  diagnostics.constraint_violation, dirac_defect):
        assert check(knife, empty).shape == (0,)


@pytest.mark.parametrize("value", [["0", "0", "0"], [True, False, True]])
def test_numbers_only(knife, value):
    with pytest.raises(TypeError, match="`q0`"):
        dmoc.simulate(knife, q0=value, v0=[1, 0, 0], steps=2)


def test_discretization_validates_when_built_directly():
    with pytest.raises(ValueError, match="`h`"):
        dmoc.Discretization(dmoc.systems.knife_edge(), -0.1)
    with pytest.raises(ValueError, match="`rule`"):
        dmoc.Discretization(dmoc.systems.knife_edge(), 0.1, "simpson")


def test_ocp_names_free_symbols_and_boundary_outside_bounds(knife):
    stray = ca.SX.sym("stray")
    base = dict(q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(ValueError, match="`running_cost` uses symbols"):
        dmoc.OptimalControlProblem(knife, 10, running_cost=lambda q, v, u: stray * ca.sumsqr(u), **base)
    with pytest.raises(ValueError, match="`path_constraints` uses symbols"):
        dmoc.OptimalControlProblem(knife, 10, path_constraints=lambda q, v, u: q[0] - stray, **base)
    with pytest.raises(ValueError, match="`q_goal` must lie within `state_bounds`"):
        dmoc.OptimalControlProblem(knife, 10, state_bounds=([-1, -1, -1], [1, 0.5, 1]), **base)


def test_expand_option_must_be_boolean():
    with pytest.raises(TypeError, match="expand"):
        dmoc.optimize(knife_edge_parking(10), options={"expand": "no"})


def test_free_time_warm_start_keeps_the_step():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    problem = dmoc.OptimalControlProblem(
        disc, 30, q_start=[0, 0, 0], q_goal=[0, 1, 0], duration=(1.0, 10.0),
        running_cost=lambda q, v, u: 1 + ca.sumsqr(u))
    first = dmoc.optimize(problem)
    assert abs(first.trajectory.h - disc.h) > 1e-3          # the optimum moved the step
    x0 = initial_guess(problem, first.trajectory)
    assert problem.x_layout.unpack(x0, "h")[0, 0] == first.trajectory.h
    again = dmoc.optimize(problem, guess=first.trajectory)
    assert again.trajectory.h == pytest.approx(first.trajectory.h, rel=1e-8)


def test_step_residual_is_built_once_per_variant(knife):
    assert dmoc.step_residual(knife) is dmoc.step_residual(knife, "+")
    with pytest.raises(ValueError, match="`variant`"):
        dmoc.step_residual(knife, "plus")
