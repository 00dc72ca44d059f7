"""The fast paths give what the plain paths give: the simulator's compiled C step (cached
on disk) against CasADi's virtual machine, with the fallback when no compiler exists; and
the optimizer's re-solve with a reused solver and its primal-dual warm start against a
fresh problem solved cold. Iteration counts and identities only, no timing."""

import shutil

import numpy as np
import pytest

import dmoc
from dmoc.optimize.guess import start_point
import dmoc.problems
from dmoc.simulate import compiled
from dmoc.simulate import stepper as stepper_module


CASES = {
    "inclined knife edge": (lambda: dmoc.systems.knife_edge(incline=0.2), [0, 0, 0.1],
                            [np.cos(0.1), np.sin(0.1), 1.0]),
    "rolling disk": (dmoc.systems.rolling_disk, [0, 0, 0, 0], [1.0, 0.0, 1.0, 0.5]),
}


@pytest.fixture
def fresh_steppers(monkeypatch, tmp_path):
    """An empty stepper cache and an empty on-disk cache directory for this test."""
    dmoc.clear_caches("steppers")
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path))
    yield tmp_path
    dmoc.clear_caches("steppers")


def _run(disc, q0, v0, variant, jit, steps=300):
    controls = np.column_stack([np.sin(0.02 * np.arange(steps)), np.ones(steps)])
    return dmoc.simulate(disc, q0=q0, v0=v0, steps=steps, controls=controls, variant=variant, jit=jit)


needs_compiler = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")


@needs_compiler
@pytest.mark.parametrize("name", CASES)
def test_compiled_step_is_bit_identical_to_the_virtual_machine(fresh_steppers, name):
    make, q0, v0 = CASES[name]
    disc = dmoc.discretize(make(), 0.02)
    for variant in ("+", "-"):
        vm, native = (_run(disc, q0, v0, variant, jit) for jit in (False, True))
        assert (vm.stats["native"], native.stats["native"]) == (False, True)
        for field in ("q", "p", "lam", "mu"):
            np.testing.assert_array_equal(getattr(vm.trajectory, field), getattr(native.trajectory, field))
        assert vm.stats["max_residual"] == native.stats["max_residual"] < 1e-12
    assert len(list(fresh_steppers.glob("dirac_step-*.so"))) == 2      # one library per variant


@needs_compiler
def test_library_is_reused_from_disk_and_default_loads_it(fresh_steppers, monkeypatch):
    make, q0, v0 = CASES["inclined knife edge"]
    disc = dmoc.discretize(make(), 0.02)
    assert _run(disc, q0, v0, "+", None).stats["native"] is False     # not cached, not long yet
    first = _run(disc, q0, v0, "+", True)
    (library,) = fresh_steppers.glob("dirac_step-*.so")
    stamp = library.stat().st_mtime_ns
    dmoc.clear_caches("steppers")     # a "new process"
    again = _run(disc, q0, v0, "+", None)
    assert again.stats["native"] is True and library.stat().st_mtime_ns == stamp
    np.testing.assert_array_equal(again.trajectory.q, first.trajectory.q)


@needs_compiler
def test_default_switches_to_compiled_code_mid_run(fresh_steppers, monkeypatch):
    monkeypatch.setattr(stepper_module, "NATIVE_AFTER_SECONDS", 0.0)
    make, q0, v0 = CASES["rolling disk"]
    disc = dmoc.discretize(make(), 0.02)
    switched = _run(disc, q0, v0, "+", None, steps=3000)
    vm = _run(disc, q0, v0, "+", False, steps=3000)
    assert switched.stats["native"] is True
    np.testing.assert_array_equal(switched.trajectory.q, vm.trajectory.q)


def test_without_a_compiler_the_default_falls_back_and_jit_true_says_why(fresh_steppers, monkeypatch):
    monkeypatch.setenv("CC", "")
    assert compiled.compiler() is None
    make, q0, v0 = CASES["inclined knife edge"]
    disc = dmoc.discretize(make(), 0.02)
    result = _run(disc, q0, v0, "+", None)
    assert result.success and result.stats["native"] is False
    assert result.stats["max_residual"] < 1e-12
    with pytest.raises(ValueError, match="C compiler"):
        _run(disc, q0, v0, "+", True)
    assert not list(fresh_steppers.glob("*.so"))


# --- re-solving and warm starts -------------------------------------------------------------

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


@pytest.mark.skipif(not shutil.which("false"), reason="no `false` command")
def test_a_failing_compiler_warns_and_falls_back(fresh_steppers, monkeypatch):
    monkeypatch.setenv("CC", "false")                  # a "compiler" that always fails
    monkeypatch.setattr(stepper_module, "NATIVE_AFTER_SECONDS", 0.0)
    make, q0, v0 = CASES["inclined knife edge"]
    disc = dmoc.discretize(make(), 0.02)
    with pytest.warns(RuntimeWarning, match="virtual machine instead"):
        result = _run(disc, q0, v0, "+", None)
    assert result.success and result.stats["native"] is False
    with pytest.raises(RuntimeError, match="compiling"):
        _run(disc, q0, v0, "+", True)


# --- configurations centered on the boundary data -----------------------------------------

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
    """options={"expand": True} expands f and g to SX while IPOPT keeps the assembled
    derivatives: the same iterations and optimum as the MX graph."""
    problem = dmoc.problems.rolling_disk_steering(30)
    mx, sx = dmoc.optimize(problem), dmoc.optimize(problem, options={"expand": True})
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


def test_with_boundary_keeps_free_entries_free():
    """Regression (review): the kept boundary data of a problem with free entries were
    passed back as NaN, which `_boundary` refuses; they stay free (None) now."""
    problem = dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), 0.1), 20,
                                         q_start=[0, 0, 0], q_goal=[0, 1, None], v_goal=[None] * 3)
    moved = problem.with_boundary(q_goal=[0.2, 1.0, None])
    assert moved.structure == problem.structure
    assert np.isnan(moved.v_goal).all() and np.isnan(moved.q_goal[2])
    assert dmoc.optimize(moved).success
