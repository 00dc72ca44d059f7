"""The region an optimum's path constraints keep out, drawn on its path
(`dmoc.results.kept_out`). Oracles written here: a keep-out disc of given centre and radius
and its closed form (r^2 - |p - c|^2), a row that reads the heading too (left out: it keeps
out no region of the plane alone), the parameter values of the problem taking the
place of w."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.results.kept_out import kept_out_region
from dmoc.results.plotting import _figures
from dmoc.systems import knife_edge

CENTRE, RADIUS = np.array([0.5, 0.4]), 0.2


def problem_with(path_constraints, **kwargs):
    disc = dmoc.discretize(knife_edge(), 0.1)
    return dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[1, 1, 0],
                                      path_constraints=path_constraints, **kwargs)


def disc_row(q, v, u):
    return RADIUS ** 2 - ca.sumsqr(q[:2] - ca.DM(CENTRE))


def test_a_disc_row_is_its_closed_form_on_the_plane():
    g = kept_out_region(problem_with(disc_row), 0, 1)
    X, Y = np.meshgrid(np.linspace(-1, 2, 7), np.linspace(-1, 2, 5))
    expected = RADIUS ** 2 - (X - CENTRE[0]) ** 2 - (Y - CENTRE[1]) ** 2
    np.testing.assert_allclose(g(X, Y), expected, rtol=0, atol=1e-15)
    assert g(X, Y).shape == X.shape


def test_rows_that_read_another_coordinate_are_left_out():
    def rows(q, v, u):
        heading = 0.1 - ca.cos(q[2])                       # reads theta
        return ca.vertcat(disc_row(q, v, u), heading, v[0] - 5.0)   # v[0]: not a knot row
    g = kept_out_region(problem_with(rows), 0, 1)
    assert g(np.array([CENTRE[0]]), np.array([CENTRE[1]]))[0] == pytest.approx(RADIUS ** 2)
    assert kept_out_region(problem_with(lambda q, v, u: 0.1 - ca.cos(q[2])), 0, 1) is None
    assert kept_out_region(problem_with(None), 0, 1) is None


def test_the_problem_parameters_take_the_place_of_w():
    def moving(q, v, u, w):
        return RADIUS ** 2 - ca.sumsqr(q[:2] - w["centre"])
    problem = problem_with(moving, parameters={"centre": CENTRE})
    g = kept_out_region(problem.with_parameters(centre=[0.0, 2.0]), 0, 1)
    assert g(np.array([0.0]), np.array([2.0]))[0] == pytest.approx(RADIUS ** 2)
    assert g(np.array(CENTRE[:1]), np.array(CENTRE[1:]))[0] < 0


def test_the_saved_path_of_an_optimum_shades_the_region():
    problem = problem_with(disc_row)
    traj = dmoc.optimize(problem).trajectory
    figures = _figures(traj, "x", problem.disc, problem, ["x", "y", "theta"], None, None,
                       None, problem.q_goal, None)
    ax = figures["path"].axes[0]
    assert "kept out" in [t.get_text() for legend in ax.artists for t in legend.get_texts()]
    bare = _figures(traj, "x", problem.disc, None, ["x", "y", "theta"], None, None, None,
                    problem.q_goal, None)["path"].axes[0]
    assert not bare.artists
