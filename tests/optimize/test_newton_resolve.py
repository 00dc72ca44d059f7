"""Warm re-solves of equality-constrained problems by Newton's method on the KKT conditions
(`dmoc.optimal_control.solver.newton_kkt`): the optimum IPOPT reaches from the same start
(the oracle: the same re-solve with an IPOPT option given, which keeps IPOPT), the KKT
conditions written here from CasADi's dense Jacobian of the NLP's expressions, a stationary
point that is not a minimum left to IPOPT, and the cases Newton does not take."""

import dataclasses

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc.optimal_control import solve
from dmoc.optimal_control.solver import newton_kkt

from .._helpers import lagrangian_gradient

IPOPT = {"fixed_variable_treatment": "make_parameter_nodual"}   # dmoc's default, given: IPOPT


@pytest.fixture(autouse=True)
def no_refusals_yet():
    """Each test starts with no structure's Newton refusals counted (other tests' re-solves
    in this process may have counted some)."""
    dmoc.clear_caches("newton_refusals")


def _problems():
    sphere = dmoc.discretize(dmoc.systems.spherical_pendulum(), 0.1)
    return {
        "rolling disk, lobatto4": (dmoc.problems.rolling_disk_steering(11, rule="lobatto4"),
                                   [1.05, 0.95, None, 1.6]),
        "knife edge, lobatto3": (dmoc.problems.knife_edge_parking(12, rule="lobatto3"), [0.05, 1.0, 0.1]),
        "spherical pendulum (holonomic), midpoint": (dmoc.OptimalControlProblem(
            sphere, 10, q_start=[np.sin(0.5), 0.0, -np.cos(0.5)], q_goal=[0.0, np.sin(0.5), None],
            v_goal=[None, 0.1, None]), [0.05, np.sin(0.5), None]),
    }


def _kkt_errors(problem, result):
    """(the largest |grad_x L| over the free entries, the largest |g|), scaled as the solvers
    see them, from the dense Jacobian (`lagrangian_gradient`)."""
    T = problem.transcription
    D, R = T.x_scale, T.g_scale
    gradient = np.array(lagrangian_gradient(T)(result.x / D, T.p, result.lam_g / R)).ravel()
    g = np.array(ca.Function("g", [T.nlp["x"], T.nlp["p"]], [T.nlp["g"]])(result.x / D, T.p)).ravel()
    return np.abs(gradient[T.lbx != T.ubx]).max(), np.abs(g - T.scaled_g_bounds[0]).max()


@pytest.mark.parametrize("name", list(_problems()))
def test_a_warm_re_solve_is_newtons_and_reaches_ipopts_optimum(name):
    problem, goal = _problems()[name]
    first = dmoc.optimize(problem)
    ours = theirs = first
    for step in (1.0, -0.5, 2.0):
        moved = problem.with_boundary(q_goal=[None if g is None else p + step * (g - p)
                                              for g, p in zip(goal, problem.q_goal)])
        ours, theirs = dmoc.optimize(moved, guess=ours), dmoc.optimize(moved, guess=theirs, options=IPOPT)
        assert (ours.stats["nlp_solver"], theirs.stats["nlp_solver"]) == ("newton", "ipopt")
        assert ours.verdict.passed and ours.stats["iterations"] <= theirs.stats["iterations"] + 1
        assert ours.message.startswith("Newton's method on the KKT conditions: Solve_Succeeded after")
        scale = max(1.0, np.abs(theirs.x).max())
        np.testing.assert_allclose(ours.x, theirs.x, rtol=0, atol=1e-8 * scale)
        np.testing.assert_allclose(ours.lam_x, theirs.lam_x, rtol=0, atol=1e-7 * max(1.0, np.abs(theirs.lam_x).max()))
        assert abs(ours.cost - theirs.cost) <= 1e-10 * abs(theirs.cost)
        stationarity, feasibility = _kkt_errors(moved, ours)
        assert stationarity <= 1e-10 and feasibility <= 1e-10


def test_a_stationary_point_that_is_not_a_minimum_is_left_to_ipopt():
    """The knife edge at rest with the running cost sum_i (u_i^4 - u_i^2): the rest
    trajectory (u = 0, the multipliers 0) satisfies the KKT conditions, a local maximum in u
    (the Hessian -2h on each u). From a warm start next to it (u = 0.2, the rest at rest)
    Newton's method converges to it; its KKT matrix there has more negative pivots than
    rows (the Hessian is negative on the constraints' tangent space), so the re-solve is
    IPOPT's. (IPOPT, with dmoc's warm options,
    also ends there on this start: the inertia test keeps Newton's claim to a minimum, it
    does not make IPOPT find one.)"""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.2)
    problem = dmoc.OptimalControlProblem(disc, 6, q_start=[0.0, 0.0, 0.0], q_goal=[0.0, 0.0, 0.0],
                                         running_cost=lambda q, v, u: ca.sum1(u ** 4 - u ** 2))
    stopped = solve(problem, options={"max_iter": 0}, throw=False)     # an OptimizationResult
    rest = dataclasses.replace(stopped, x=np.zeros_like(stopped.x), lam_g=np.zeros_like(stopped.lam_g))
    assert max(_kkt_errors(problem, rest)) == 0.0           # a KKT point
    T = problem.transcription
    near = rest.x.copy()
    near[T.x_layout.slice("u")] = 0.2
    n_x, n_g = near.size, T.g_layout.size
    step, signs = newton_kkt._newton_step(T, np.flatnonzero(T.lbx == T.ubx))
    z = np.concatenate([near / T.x_scale, T.p, np.zeros(n_g)])
    for _ in range(8):
        out = step.vector(z)
        z[:n_x], z[-n_g:] = out[:n_x], out[n_x:-2]
    assert np.abs(z[:n_x]).max() < 1e-12                                # Newton's limit: the rest
    assert signs.vector(z)[0] > n_g           # negative curvature on the constraints' tangent space
    result = solve(problem, guess=dataclasses.replace(rest, x=near))
    assert result.stats["warm_start"] and result.stats["nlp_solver"] == "ipopt"


def test_bounds_options_and_cold_starts_stay_with_ipopt():
    """Newton applies to warm re-solves of problems whose rows are all equalities and whose
    only bounded entries are fixed, with no IPOPT `options` but its tolerances and
    print_level."""
    problem, _ = _problems()["knife edge, lobatto3"]
    first = solve(problem)
    assert first.stats["nlp_solver"] == "ipopt"                                    # cold
    assert solve(problem, guess=first, options=IPOPT).stats["nlp_solver"] == "ipopt"  # options
    assert solve(problem, guess=first).stats["nlp_solver"] == "newton"
    assert solve(problem, guess=first, options={"print_level": 0, "tol": 1e-9}).stats["nlp_solver"] == "newton"
    bounded = dmoc.OptimalControlProblem(problem.disc, problem.steps, q_start=problem.q_start,
                                         q_goal=problem.q_goal, control_bounds=([-5.0, -5.0], [5.0, 5.0]))
    assert not newton_kkt.applies(bounded.transcription, bounded.transcription.lbx / bounded.transcription.x_scale,
                                  bounded.transcription.ubx / bounded.transcription.x_scale,
                                  *bounded.transcription.scaled_g_bounds)
    again = solve(bounded, guess=solve(bounded))
    assert again.stats["warm_start"] and again.stats["nlp_solver"] == "ipopt"


def test_a_structure_newton_keeps_refusing_goes_to_ipopt_at_once(monkeypatch):
    """A car in SI units (1500 kg, 2500 kg m², 60 m at 10 m/s): its scaled NLP spans 1e9 and
    Newton's iteration stalls above tol, so every attempt is refused (IPOPT re-solves, the
    verdict passes); after REFUSALS_BEFORE_IPOPT refusals in a row the structure's
    re-solves no longer try it (its steps are not even looked up)."""
    car = dmoc.systems.car(mass=1500.0, yaw_inertia=2500.0, com_offset=0.4)
    problem = dmoc.OptimalControlProblem(dmoc.discretize(car, 0.2, "lobatto3"), 30, q_start=[0, 0, 0, 0],
                                         v_start=[10, 0, 0, 0], q_goal=[60, 3.5, 0, 0], v_goal=[10, 0, 0, 0])
    result = dmoc.optimize(problem)
    for dy in range(newton_kkt.REFUSALS_BEFORE_IPOPT):
        result = dmoc.optimize(problem.with_boundary(q_goal=[60, 3.6 + 0.1 * dy, 0, 0]), guess=result)
        assert result.stats["nlp_solver"] == "ipopt" and result.verdict.passed

    class Untouched:
        def get(self, *args):
            raise AssertionError("Newton's steps looked up after the refusals")
    monkeypatch.setattr(newton_kkt, "_STEPS", Untouched())
    again = dmoc.optimize(problem.with_boundary(q_goal=[60, 3.3, 0, 0]), guess=result)
    assert again.stats["nlp_solver"] == "ipopt" and again.verdict.passed
