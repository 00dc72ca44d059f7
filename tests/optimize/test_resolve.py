"""Re-solving is what solving afresh gives: a problem with new boundary data reuses the NLP
and the solver, a warm start from a neighbouring optimum (in memory or saved) reaches the
same optimum in fewer iterations, a result of another grid is resampled, free entries stay
free, and the expanded oracle gives the same optimum.

Oracle: the fresh problem solved cold by a fresh solver; IPOPT's own iteration counts.
Iteration counts and identities only, no timing."""

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc.optimal_control import initial_guess
from dmoc.optimal_control.solver.guess import start_point


GOAL, NEIGHBOUR = (0.0, 1.0, 0.0), (0.1, 1.1, 0.1)


@pytest.mark.parametrize("variant", ["+", "-"])
def test_resolve_with_new_boundary_data_equals_a_fresh_problem(variant):
    problem = dmoc.problems.knife_edge_parking(40, goal=GOAL, variant=variant)
    dmoc.optimize(problem)
    moved = problem.with_boundary(q_goal=NEIGHBOUR)
    assert moved.structure == problem.structure and moved.nlp is problem.nlp
    again = dmoc.optimize(moved)
    fresh = dmoc.optimize(dmoc.problems.knife_edge_parking(40, goal=NEIGHBOUR, variant=variant))
    assert again.stats["solver_reused"] and again.stats["build_time"] == 0.0
    assert 0 < again.stats["function_time"] < again.stats["solve_time"]
    # IPOPT's call as CasADi times it holds the evaluations and lies within the packed call
    assert again.stats["function_time"] < again.stats["ipopt_time"] <= again.stats["solve_time"]
    regularized = again.stats["regularized_iterations"]
    assert 0 <= regularized <= again.stats["iterations"]
    assert (regularized == 0) == (again.stats["max_regularization"] == 0)
    assert np.abs(again.x - fresh.x).max() <= 1e-10
    np.testing.assert_array_equal(moved.q_goal, NEIGHBOUR)
    np.testing.assert_array_equal(problem.q_goal, GOAL)                # the original is untouched


@pytest.mark.parametrize("variant", ["+", "-"])
def test_warm_start_from_the_neighbouring_optimum_halves_the_iterations(variant):
    problem = dmoc.problems.knife_edge_parking(60, goal=GOAL, variant=variant)
    neighbour = dmoc.optimize(problem)
    moved = problem.with_boundary(q_goal=NEIGHBOUR)
    cold = dmoc.optimize(moved)
    warm = dmoc.optimize(moved, guess=neighbour)
    assert warm.stats["warm_start"] and not cold.stats["warm_start"]
    assert 2 * warm.stats["iterations"] <= cold.stats["iterations"]
    assert abs(warm.cost - cold.cost) <= 1e-10
    assert np.abs(warm.trajectory.q - cold.trajectory.q).max() <= 1e-8


def test_saved_result_warm_starts_and_another_grid_is_resampled(tmp_path):
    problem = dmoc.problems.knife_edge_parking(30)
    result = dmoc.optimize(problem)
    result.save(tmp_path / "opt.npz")
    loaded = dmoc.OptimizationResult.load(tmp_path / "opt.npz")
    for name in ("x", "lam_x", "lam_g"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(result, name))
    assert (loaded.cost, loaded.status, loaded.structure) == (result.cost, result.status, result.structure)
    np.testing.assert_array_equal(dmoc.Trajectory.load(tmp_path / "opt.npz").q, result.trajectory.q)
    moved = problem.with_boundary(q_goal=NEIGHBOUR)
    from_file, from_memory = (dmoc.optimize(moved, guess=g) for g in (loaded, result))
    assert from_file.stats["warm_start"]
    np.testing.assert_array_equal(from_file.x, from_memory.x)
    finer = dmoc.problems.knife_edge_parking(45)            # another grid: primal resampled
    resampled = dmoc.optimize(finer, guess=loaded)
    assert not resampled.stats["warm_start"]
    assert abs(resampled.cost - dmoc.optimize(finer).cost) <= 1e-10


def test_with_boundary_rebuilds_when_an_end_becomes_free():
    problem = dmoc.problems.knife_edge_parking(30)
    at_rest = problem.with_boundary(q_goal=[0.0, 1.0, None])     # v_goal = 0: no rows needed
    assert at_rest.structure == problem.structure and at_rest.g_layout.numel("goal_velocity") == 0
    free = problem.with_boundary(v_goal=[None, None, 0.0])
    assert free.structure != problem.structure and free.g_layout.numel("goal_velocity") == 1
    direct = dmoc.OptimalControlProblem(problem.disc, 30, q_start=[0, 0, 0], q_goal=[0.0, 1.0, 0.0],
                                        v_goal=[None, None, 0.0])
    assert free.structure == direct.structure
    assert abs(dmoc.optimize(free).cost - dmoc.optimize(direct).cost) <= 1e-12
    with pytest.raises(ValueError, match="v_goal"):
        problem.with_boundary(v_goal=[0.0, 1.0, 0.0])


def test_constraint_jacobian_has_full_row_rank_with_a_free_goal_angle():
    """Regression: with the rolling angle free at the goal and v_goal = 0 given, the rows
    A(q_N) v_N = 0 vanished identically, so every KKT matrix was singular (IPOPT
    perturbed it at every iteration). Now no such rows, and the Jacobian of g with
    respect to the free variables has full row rank at the optimum."""
    problem = dmoc.problems.rolling_disk_steering(6)
    assert problem.g_layout.numel("goal_velocity") == 0
    result = dmoc.optimize(problem)
    J = np.array(problem.separable.derivatives()["nlp_jac_g"](result.x, problem.p)[1])
    free = problem.lbx != problem.ubx
    singular_values = np.linalg.svd(J[:, free], compute_uv=False)
    assert singular_values.min() > 1e-6 * singular_values.max()


def test_warm_start_moves_with_the_reference():
    """with_boundary(q_start=...) moves q_ref; the warm start re-centers the neighbour's x
    on it, so it starts near the new optimum (fewer iterations than cold, same optimum)."""
    problem = dmoc.problems.knife_edge_parking(60)
    neighbour = dmoc.optimize(problem)
    moved = problem.with_boundary(q_start=[0.1, 0.05, 0.0], q_goal=[0.1, 1.05, 0.0])
    np.testing.assert_array_equal(moved.q_ref, [0.1, 0.05, 0.0])
    x0 = start_point(moved, neighbour)[0]        # the neighbour's configurations,
    np.testing.assert_allclose(moved.configurations(x0)[1:-1],  # the ends clipped to the new data
                               neighbour.trajectory.q[1:-1], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(moved.configurations(x0)[[0, -1]], [[0.1, 0.05, 0.0], [0.1, 1.05, 0.0]])
    warm, cold = dmoc.optimize(moved, guess=neighbour), dmoc.optimize(moved)
    assert warm.stats["warm_start"]
    assert 2 * warm.stats["iterations"] <= cold.stats["iterations"]
    assert np.abs(warm.trajectory.q - cold.trajectory.q).max() <= 1e-8
    # a pure translation: the same motion, shifted
    assert np.abs(warm.trajectory.q - [0.1, 0.05, 0.0] - neighbour.trajectory.q).max() <= 1e-8


def test_guess_from_another_grid_starts_from_least_squares_multipliers():
    """A result of another grid gives its trajectory, resampled; IPOPT then estimates the
    multipliers by least squares at that point (warm_start_init_point "no"), which takes
    fewer iterations than starting from zero multipliers, to the same optimum."""
    coarse = dmoc.optimize(dmoc.problems.knife_edge_parking(50))
    fine = dmoc.problems.knife_edge_parking(100)
    estimated = dmoc.optimize(fine, guess=coarse)
    zero = dmoc.optimize(fine, guess=coarse, options={"warm_start_init_point": "yes"})
    assert not estimated.stats["warm_start"]
    assert estimated.stats["iterations"] < zero.stats["iterations"]
    assert abs(estimated.cost - zero.cost) <= 1e-10 * zero.cost


def test_expanded_oracle_gives_the_same_optimum():
    """expand=True expands f, g and
    the assembled derivatives to SX: the same iterations and optimum as the MX graph
    (bit for bit: tests/optimize/test_evaluation.py)."""
    problem = dmoc.problems.rolling_disk_steering(30)
    mx, sx = dmoc.optimize(problem), dmoc.optimize(problem, expand=True)
    assert sx.stats["iterations"] == mx.stats["iterations"]
    assert abs(sx.cost - mx.cost) <= 1e-12 * mx.cost
    assert np.abs(sx.x - mx.x).max() <= 1e-10


def test_result_without_q_ref_loads_and_starts_primal_only(tmp_path):
    """A result file written before results kept q_ref (or a result built by hand without
    it) loads, and as a guess it gives its trajectory (no re-centering is possible)."""
    problem = dmoc.problems.knife_edge_parking(20)
    result = dmoc.optimize(problem)
    result.q_ref = None
    result.save(tmp_path / "old.npz")
    loaded = dmoc.OptimizationResult.load(tmp_path / "old.npz")
    assert loaded.q_ref is None
    again = dmoc.optimize(problem, guess=loaded)
    assert again.success and not again.stats["warm_start"]
    assert abs(again.cost - result.cost) <= 1e-10 * result.cost


def test_with_boundary_keeps_free_entries_free():
    """Regression (review): the kept boundary data of a problem with free entries were
    passed back as NaN, which `_boundary` refuses; they stay free (None) now."""
    problem = dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), 0.1), 20,
                                         q_start=[0, 0, 0], q_goal=[0, 1, None], v_goal=[None] * 3)
    moved = problem.with_boundary(q_goal=[0.2, 1.0, None])
    assert moved.structure == problem.structure
    assert np.isnan(moved.v_goal).all() and np.isnan(moved.q_goal[2])
    assert dmoc.optimize(moved).success


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


def test_the_function_time_is_the_sum_of_every_nlp_functions_wall_time():
    """stats["function_time"] sums the five Functions' wall times by name
    (`ipopt.linear_algebra`); the oracle is every ``t_wall_nlp_*`` entry of the solver's
    own statistics, summed in their order: the same bits, and no NLP Function left out."""
    from dmoc.optimal_control.solver import ipopt
    problem = dmoc.problems.knife_edge_parking(12)
    result = dmoc.optimize(problem, check=False)
    solver = ipopt.solver(problem.transcription, ipopt.start_options(False), expand=False,     # the one
                          reuse=True, report=False, jit=result.stats["compiled"])[0]      # it solved on
    st = solver.stats()
    assert st["n_call_nlp_hess_l"] > 0
    assert result.stats["function_time"] == sum(v for k, v in st.items() if k.startswith("t_wall_nlp_"))
