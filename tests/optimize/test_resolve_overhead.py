"""What a raw re-solve leaves out or does once is the same as what it did before, bit for
bit (issue 25; benchmarks/peers.py resolve times the re-solves): the result's
trajectory, made on first access, is the one `trajectory_from_x` makes of the returned x
at once; the data's row sums of one stacked [x; p] (q_ref added to the configurations
inside the Function) are those of the former [x; x_abs; p], x_abs formed in NumPy.

Oracles: `trajectory_from_x` called on the result's x (the path `solve` took before), and
the former row-sum Function written out below (a separate code path, the same Jacobian).
"""

import copy
import pickle
import threading

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc._util.compiled import compiler
from dmoc._util.deferred import Pending
from dmoc._util.numeric import Evaluator
from dmoc.optimal_control.solver import ipopt
from dmoc.optimal_control.nlp.evaluation import nlp_functions
from dmoc.optimal_control.solver.optimization_result import OptimizationResult
from dmoc.optimal_control.solver.guess import initial_guess as ipopt_start_vector
from dmoc.optimal_control.solver.solving import solve, trajectory_from_x

FIELDS = ("t", "q", "p", "lam", "u", "h", "variant", "mu", "s", "control_nodes", "stage_nodes")


def _same_trajectory(a, b):
    for f in FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y), f
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, f
            np.testing.assert_array_equal(x.view(np.int64), y.view(np.int64), err_msg=f)
        else:
            assert x == y, f


def _problems():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    return {"parking": dmoc.problems.knife_edge_parking(12),
            "rolling disk lobatto4": dmoc.problems.rolling_disk_steering(8, rule="lobatto4"),
            "carried momenta, (-)": dmoc.OptimalControlProblem(
                disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0], momenta="variables", variant="-"),
            "free final time": dmoc.OptimalControlProblem(
                disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0], duration=(0.5, 3.0))}


@pytest.mark.parametrize("name", list(_problems()))
def test_a_re_solves_trajectory_is_made_on_first_access_as_before(name):
    """Cold and warm re-solve (new goal, the previous optimum as guess): nothing is made
    until the field is read; then the fields are `trajectory_from_x`'s of the result's x,
    bit for bit, kept (the same object on the next read), and a write into result.x
    before the first read does not reach them."""
    problem = _problems()[name]
    cold = solve(problem)
    goal = np.where(np.isfinite(problem.q_goal), problem.q_goal + 0.05, np.nan)
    warm = solve(problem.with_boundary(q_goal=[None if np.isnan(g) else g for g in goal]), guess=cold)
    for result, stated in ((cold, problem), (warm, None)):
        assert isinstance(vars(result)["trajectory"], Pending)
        x = result.x.copy()
        result.x[:] = np.nan                    # the trajectory is of the x IPOPT returned
        made = result.trajectory
        result.x[:] = x
        assert made is result.trajectory and vars(result)["trajectory"] is made
        if stated is not None:
            _same_trajectory(made, trajectory_from_x(stated, x))
    _same_trajectory(warm.trajectory, trajectory_from_x(
        problem.with_boundary(q_goal=[None if np.isnan(g) else g for g in goal]), warm.x))


def test_pickles_copies_and_field_copies_hold_the_trajectory_itself():
    """A pickle (dmoc.batch ships results as guesses), a copy and a result built from
    ``vars(result)`` give the trajectory that the original gives."""
    problem = dmoc.problems.knife_edge_parking(10)
    for make in (lambda r: pickle.loads(pickle.dumps(r)), copy.copy, copy.deepcopy,
                 lambda r: OptimizationResult(**vars(r))):
        result = solve(problem)
        other = make(result)
        _same_trajectory(other.trajectory, trajectory_from_x(problem, result.x))
        np.testing.assert_array_equal(other.x, result.x)


def test_a_judged_optimum_and_a_failed_solve_carry_the_same_trajectory():
    """`dmoc.optimize` (the verdict reads the trajectory) and a solve stopped by max_iter
    (the last iterate) give `trajectory_from_x` of their x."""
    problem = dmoc.problems.knife_edge_parking(40)
    judged = dmoc.optimize(problem)
    stopped = solve(problem, options={"max_iter": 2}, throw=False)
    assert judged.verdict is not None and not stopped.success
    for result in (judged, stopped):
        _same_trajectory(result.trajectory, trajectory_from_x(problem, result.x))


def _former_largest_row_sum(T, x0, jit):
    """`data_tolerances`' row sums as computed before: [x; x_abs; p], x_abs formed in NumPy
    by `Transcription.configurations`."""
    separable = T.separable
    n_x, n_p = separable.n_x, separable.n_p
    z = ca.MX.sym("z", 2 * n_x + n_p)
    x, x_abs, p = z[:n_x], z[n_x:2 * n_x], z[2 * n_x:]
    jacobian = nlp_functions(separable, jit=jit)["nlp_jac_g"](x, p)[1]
    rows = ca.mtimes(ca.fabs(jacobian), ca.fabs(x_abs))
    largest = ca.Function("former", [z], [ca.mmax(rows)])
    absolute = np.array(x0, dtype=float)
    absolute[T.x_layout.slice("q")] = T.configurations(x0).ravel()
    return float(largest(ca.DM(np.concatenate([x0, absolute, T.p]))))


@pytest.mark.parametrize("jit", [False, pytest.param(True, marks=pytest.mark.skipif(
    compiler() is None, reason="jit=True needs a C compiler"))])
def test_the_row_sums_of_one_stacked_x_and_p_are_the_former_ones(jit):
    """At random points of every scale (1e-3 to 1e6) of a problem near and one far from
    the origin (q ~ 1e6, where the floor rises above 1e-10): the same float."""
    rng = np.random.default_rng(7)
    near = dmoc.problems.rolling_disk_steering(6, rule="lobatto4")
    far = dmoc.problems.knife_edge_parking(8).with_boundary(q_start=[1e6, -3e5, 0.3],
                                                            q_goal=[1e6 + 1.0, -3e5, 0.2])
    for problem in (near, far):
        T = problem.transcription
        largest = ipopt._largest_row_sum(T, jit)
        through_buffer = Evaluator(largest)        # as `data_tolerances` calls it
        for _ in range(10):
            x0 = rng.normal(size=T.x_layout.size) * 10.0 ** rng.uniform(-3, 6)
            z = np.concatenate([x0, T.p])
            assert float(largest(ca.DM(z))) == _former_largest_row_sum(T, x0, jit) == \
                through_buffer(z)[0][0, 0]
    assert ipopt.data_tolerances(far.transcription, far.transcription.lbx.clip(-1e7, 1e7))


@pytest.mark.parametrize("name", ["rolling disk lobatto4", "parking", "free final time"])
def test_warm_re_solves_with_the_warm_options_take_the_same_iterations(name):
    """A warm start runs IPOPT with ``fast_step_computation`` "yes"
    (`ipopt.WARM_START_OPTIONS`) and MUMPS's own scaling; the oracle is the same chain of
    re-solves with IPOPT's own defaults ("no", and ``mumps_scaling`` 77) given in
    `options`: the same iterations, optima within 1e-12, and a first solve unchanged (the
    cold options keep IPOPT's defaults: the same bits as with them given)."""
    defaults = {"mumps_scaling": 77, "fast_step_computation": "no"}
    # an option that changes nothing keeps the warm re-solves IPOPT's (without `options`
    # an equality-constrained one is Newton's, `dmoc.optimal_control.solver.newton_kkt`)
    IPOPT_DEFAULT_TREATMENT = {"fixed_variable_treatment": "make_parameter_nodual"}
    assert ipopt.start_options(True)["fast_step_computation"] == "yes"
    assert "mumps_scaling" not in ipopt.start_options(True)
    assert not defaults.keys() & ipopt.start_options(False).keys()
    problem = _problems()[name]
    cold, plain = solve(problem), solve(problem, options=defaults)
    np.testing.assert_array_equal(cold.x, plain.x)
    for step in (0.02, 0.05, -0.03, 0.3):
        goal = [None if np.isnan(g) else g + step for g in problem.q_goal]
        moved = problem.with_boundary(q_goal=goal)
        cold = solve(moved, guess=cold, options=IPOPT_DEFAULT_TREATMENT)
        plain = solve(moved, guess=plain, options=defaults)
        assert cold.stats["warm_start"] and cold.stats["iterations"] == plain.stats["iterations"]
        np.testing.assert_allclose(cold.x, plain.x, rtol=0.0, atol=1e-12 * max(1.0, np.abs(plain.x).max()))


@pytest.mark.parametrize("name", ["rolling disk lobatto4", "free final time"])
def test_the_packed_call_through_its_buffer_gives_the_solvers_own_outputs(name):
    """`ipopt.PackedSolver` hands its stacked input to CasADi through the packed
    Function's buffer (no conversion); the oracle is the nlpsol it wraps called on the
    eight NumPy inputs one by one (CasADi's own conversions): every output the same bits,
    cold and warm."""
    problem = _problems()[name]
    T = problem.transcription
    first = solve(problem)
    packed = ipopt.solver(T, ipopt.start_options(True), expand=False, reuse=True, report=False)[0]
    D, R = T.x_scale, T.g_scale
    inputs = {"x0": first.x / D + 0.01, "p": T.p, "lam_x0": first.lam_x * D, "lam_g0": first.lam_g / R,
              "lbx": T.lbx / D, "ubx": T.ubx / D, "lbg": T.lbg * R, "ubg": T.ubg * R}
    ours = packed(**inputs)
    theirs = {key: np.array(value).ravel() for key, value in packed.nlpsol(**inputs).items()}
    assert packed.stats()["iter_count"] > 0
    for key in ("x", "f", "g", "lam_x", "lam_g"):
        np.testing.assert_array_equal(ours[key].view(np.int64), theirs[key].view(np.int64), err_msg=key)
    # what the packed call adds, by its definition: the entries of x with lbx < ubx on a
    # bound, and the largest violation of the unscaled rows with its first row
    x, lbx, ubx = theirs["x"], inputs["lbx"], inputs["ubx"]
    assert ours["on_bound"][0] == np.count_nonzero((lbx < ubx) & ((x == lbx) | (x == ubx)))
    g = theirs["g"] / R
    violation = np.maximum(T.lbg - g, g - T.ubg)
    row = int(np.argmax(violation)) if violation.max() > 0 else 0
    assert (ours["largest"][0], ours["row"][0]) == (max(violation.max(), 0.0), row)
    # and the result's vectors in the system's units, as NumPy forms them, the same bits
    for key, value in (("result_x", D * x), ("result_lam_x", theirs["lam_x"] / D),
                       ("result_lam_g", R * theirs["lam_g"])):
        np.testing.assert_array_equal(ours[key].view(np.int64), value.view(np.int64), err_msg=key)
    assert ours["x_norm1"][0] == sum(abs(v) for v in (D * x).tolist())     # in order, from 0


def test_a_returned_x_that_is_not_finite_is_seen_and_its_trajectory_made_at_once():
    """IPOPT stopped by a NaN in its start point returns it in x: the packed call's
    1-norm of x is not finite, and the result's trajectory is made at once by the checking
    constructor (`trajectory_from_x`), not deferred; the oracle is NumPy's isfinite of the
    returned x."""
    from dmoc.optimal_control.solver.solving import _result
    problem = dmoc.problems.knife_edge_parking(6)
    T = problem.transcription
    packed = ipopt.solver(T, ipopt.start_options(False), expand=False, reuse=True, report=False)[0]
    D, R = T.x_scale, T.g_scale
    x0 = ipopt_start_vector(problem) / D
    x0[np.flatnonzero(T.lbx < T.ubx)[3]] = np.nan
    sol = packed(x0=x0, p=T.p, lam_x0=np.zeros_like(x0), lam_g0=np.zeros(T.lbg.size), lbx=T.lbx / D,
                 ubx=T.ubx / D, lbg=T.lbg * R, ubg=T.ubg * R)
    assert not np.isfinite(sol["result_x"]).all() and not np.isfinite(sol["x_norm1"][0])
    result = _result(problem, packed, sol, np.flatnonzero(T.lbx == T.ubx), (np.nan, False, "s", "m", {}))
    assert not isinstance(vars(result)["trajectory"], Pending)
    np.testing.assert_array_equal(result.x, sol["result_x"])


def test_a_solve_in_another_thread_reports_its_own_stats():
    """The packed call has a buffer per thread (made on the thread's first call) and
    reads IPOPT's statistics through it: a warm re-solve in the main thread and then a
    cold solve in another thread on the one cached solver each report the iterations
    (and x) of the same solve made alone on a solver of its own (``reuse_solver=False``:
    the oracle)."""
    problem = dmoc.problems.knife_edge_parking(12)
    first = solve(problem)
    moved = problem.with_boundary(q_goal=[0.1, 1.1, 0.1])
    cold = {"options": dict(ipopt.WARM_START_OPTIONS)}      # the warm solve's solver, zero multipliers
    alone = {"warm": solve(moved, guess=first, reuse_solver=False),
             "cold": solve(moved, reuse_solver=False, **cold)}
    assert alone["warm"].stats["iterations"] != alone["cold"].stats["iterations"]
    got = {"warm": solve(moved, guess=first)}
    thread = threading.Thread(target=lambda: got.update(cold=solve(moved, **cold)))
    thread.start()
    thread.join()
    assert got["cold"].stats["solver_reused"]      # the solver the warm solve built
    for key, result in got.items():
        assert result.stats["iterations"] == alone[key].stats["iterations"], key
        np.testing.assert_array_equal(result.x, alone[key].x, err_msg=key)


def _former_key(options, report):
    """The solver cache's key of the options before they were kept per set: the repr of
    the sorted nlpsol options, made at every solve."""
    merged = {**ipopt.DEFAULT_IPOPT_OPTIONS, **options}
    if report:
        merged["file_print_level"] = ipopt.JOURNAL_LEVEL
    opts = {"print_time": False, "error_on_fail": False, "no_nlp_grad": True, "calc_lam_p": False,
            "record_time": True, **{"ipopt." + k: v for k, v in merged.items()}}
    return repr(sorted(opts.items()))


def test_solvers_are_shared_exactly_when_the_former_keys_agree(monkeypatch):
    """The nlpsol options and their key are kept per set of defaults, options (by their
    reprs) and report: two solves share a solver exactly when the former key, made anew
    at every solve, says so; changing DEFAULT_IPOPT_OPTIONS gives another solver."""
    problem = dmoc.problems.knife_edge_parking(6)
    T = problem.transcription
    sets = [({}, False), ({}, False), ({"tol": 1e-8}, False), ({"tol": 1.0e-8}, False),
            ({"tol": np.float64(1e-8)}, False), ({"print_level": 0}, False),
            ({"print_level": 0.0}, False), ({"mu_strategy": "adaptive", "tol": 1e-8}, False),
            ({"tol": 1e-8, "mu_strategy": "adaptive"}, False), ({}, True),
            ({"file_print_level": 3}, True), (ipopt.start_options(True), False)]
    solvers = [ipopt.solver(T, dict(options), expand=False, reuse=True, report=report)[0]
               for options, report in sets]
    for i, (a, ka) in enumerate(zip(solvers, sets)):
        for b, kb in zip(solvers[i:], sets[i:]):
            assert (a is b) == (_former_key(*ka) == _former_key(*kb)), (ka, kb)
    monkeypatch.setitem(ipopt.DEFAULT_IPOPT_OPTIONS, "max_iter", 999)
    changed = ipopt.solver(T, {}, expand=False, reuse=True, report=False)[0]
    assert changed is not solvers[0]
