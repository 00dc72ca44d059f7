"""Problems far from the origin: the NLP holds q - q_ref, so the optimum there is the
translated optimum near it, a saved result keeps its reference, and guesses that differ
slightly share one solver; the tolerances IPOPT is given are raised to the rounding floor
of the rows there, rounded up to a power of 2.

Oracles, none taken from the code under test: the knife edge's invariance under
translation (its L and A(q) depend on theta only): the same problem solved near the
origin, with IPOPT's own status and iteration count; the rounding floor
eps * max_i sum_j |dg_i/dx_j| |x_j| written here from CasADi's own Jacobian of the NLP's g."""

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc.optimal_control.solver import ipopt
from dmoc.optimal_control.solver.guess import start_point
from dmoc.systems import knife_edge

FAR = np.array([3.0e5, -2.0e5, 0.0])        # map coordinates: metres from a distant origin


def test_far_from_the_origin_the_optimum_is_the_translated_one():
    """q_ref = q_start: the NLP holds q - q_ref, so the optimum far from the origin is the
    translated optimum near it (translation invariance of the knife edge), to the rounding
    of the coordinates."""
    near = dmoc.optimize(dmoc.problems.knife_edge_parking(40))
    disc = near.trajectory.h
    problem = dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=1.0), disc),
                                         40, q_start=FAR, q_goal=FAR + [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(problem.q_ref, FAR)
    far = dmoc.optimize(problem)
    np.testing.assert_array_equal(problem.x_layout.unpack(far.x, "q")[:, 0], [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(far.trajectory.q, problem.configurations(far.x))
    assert far.cost == pytest.approx(near.cost, rel=1e-9)
    eps_q = np.finfo(float).eps * np.abs(FAR).max()
    assert np.abs(far.trajectory.q - FAR - near.trajectory.q).max() <= 1e3 * eps_q


def test_saved_result_keeps_its_reference(tmp_path):
    """A saved result knows the q_ref its x is centered on, so a loaded result warm-starts
    a neighbouring problem far from the origin (the configurations it holds are absolute)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=1.0), 0.1)
    problem = dmoc.OptimalControlProblem(disc, 40, q_start=FAR, q_goal=FAR + [0.0, 1.0, 0.0])
    result = dmoc.optimize(problem)
    result.save(tmp_path / "far.npz")
    loaded = dmoc.OptimizationResult.load(tmp_path / "far.npz")
    np.testing.assert_array_equal(loaded.q_ref, FAR)
    moved = problem.with_boundary(q_start=FAR + [0.05, 0.0, 0.0])
    warm, cold = dmoc.optimize(moved, guess=loaded), dmoc.optimize(moved)
    assert warm.success and 2 * warm.stats["iterations"] <= cold.stats["iterations"]
    assert abs(warm.cost - cold.cost) <= 1e-8 * cold.cost


def test_far_problems_share_a_solver_across_start_points():
    """The data tolerance far from the origin is rounded to a power of 2, so guesses that
    differ slightly reuse one solver instead of building one each."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=1.0), 0.04)
    problem = dmoc.OptimalControlProblem(disc, 40, q_start=FAR * 3, q_goal=FAR * 3 + [0.0, 1.0, 0.0])
    first = dmoc.optimize(problem)
    reused = []
    for scale in (0.98, 1.0, 1.02):
        guess = dmoc.Trajectory(first.trajectory.t, FAR * 3 + scale * (first.trajectory.q - FAR * 3),
                                first.trajectory.p, first.trajectory.lam, first.trajectory.u,
                                first.trajectory.h, "+")
        reused.append(dmoc.optimize(problem, guess=guess).stats["solver_reused"])
    assert all(reused)


def test_optimum_is_translation_invariant():
    disc = dmoc.discretize(knife_edge(), 0.04)
    shift = np.array([1e6, 1e6, 0.0])
    results = [dmoc.optimize(dmoc.OptimalControlProblem(disc, 20, q_start=d, q_goal=d + [0, 1, 0]),
                             throw=False) for d in (np.zeros(3), shift)]
    assert results[1].success, results[1].message
    assert results[1].cost == pytest.approx(results[0].cost, rel=1e-6)


def far_parking(h, at=FAR):
    """The unit-inertia knife edge parked by (0, 1, 0) from `at` (unit inertia: the NLP is
    not scaled, so IPOPT sees x and g as the problem writes them)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=1.0, inertia=1.0), h)
    return dmoc.OptimalControlProblem(disc, 40, q_start=at, q_goal=at + [0.0, 1.0, 0.0])


def test_far_from_the_origin_ipopt_converges_as_near_it():
    """IPOPT's tolerance is raised with the constraint tolerance to the rows' rounding
    floor: far from the origin IPOPT then stops with Solve_Succeeded after as many
    iterations as the translated problem near the origin. With `tol` left at 1e-10 it cannot
    reach it there and stops at Solved_To_Acceptable_Level after more iterations."""
    near = dmoc.optimize(dmoc.problems.knife_edge_parking(40))
    far = dmoc.optimize(far_parking(near.trajectory.h))
    assert near.status == far.status == "Solve_Succeeded"
    assert far.stats["iterations"] == near.stats["iterations"]


@pytest.mark.parametrize("at", [FAR, 3 * FAR])
def test_data_tolerance_is_the_rounding_floor_rounded_up_to_a_power_of_two(at):
    """The documented rule of `data_tolerances`: tol = constr_viol_tol = the smallest power
    of 2 not below eps * max_i sum_j |dg_i/dx_j| |x_j|, x the start point with its
    configurations absolute; the floor here is not itself a power of 2."""
    problem = far_parking(0.1, at)
    assert (problem.x_scale == 1.0).all() and (problem.g_scale == 1.0).all()
    x0 = start_point(problem, None)[0]
    jacobian = ca.Function("J", [problem.nlp["x"], problem.nlp["p"]],
                           [ca.jacobian(problem.nlp["g"], problem.nlp["x"])])
    J = np.array(ca.DM(jacobian(x0, problem.p)))
    x = x0.copy()
    x[problem.x_layout.slice("q")] = (problem.x_layout.unpack(x0, "q") + problem.q_ref[:, None]).T.ravel()
    floor = np.finfo(float).eps * (np.abs(J) @ np.abs(x)).max()
    tolerances = ipopt.data_tolerances(problem, x0)
    assert tolerances["tol"] == tolerances["constr_viol_tol"]
    tol = tolerances["tol"]
    assert tol == 2.0 ** round(np.log2(tol)) and floor != 2.0 ** round(np.log2(floor))
    assert floor <= tol < 2 * floor
