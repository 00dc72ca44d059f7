"""IPOPT's NLP scaling left out where it would be the identity (`dmoc.optimize.ipopt.
data_options`): IPOPT's default "gradient-based" scaling scales f and the rows only where
an entry of grad f or of the Jacobian at the start point exceeds 100, so below that dmoc
runs IPOPT with ``nlp_scaling_method`` "none", the same iterates without the scaling's
evaluations (docs/performance.md, "The re-solve, sixth pass").

Oracle: IPOPT itself, the same solves with ``nlp_scaling_method`` "gradient-based" given
in `options` (IPOPT determines its scaling factors itself), and the gradient and Jacobian
written out below from the NLP's expressions with CasADi's dense AD.
"""

import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc._util.compiled import compiler
from dmoc.optimize import ipopt
from dmoc.optimize.guess import start_point
from dmoc.optimize.solve import solve

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
from lane_change_problem import lane_change  # noqa: E402

GRADIENT_BASED = {"nlp_scaling_method": "gradient-based"}
MODES = [{}, pytest.param({"jit": True}, marks=pytest.mark.skipif(
    compiler() is None, reason="jit=True needs a C compiler"))]


def _problems():
    knife = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    sphere = dmoc.discretize(dmoc.systems.spherical_pendulum(), 0.1, rule="midpoint")
    return {
        "knife edge": (dmoc.problems.knife_edge_parking(12), [0.05, 1.0, 0.1]),
        "rolling disk": (dmoc.problems.rolling_disk_steering(11, rule="lobatto4", duration=4.0),
                         [1.05, 0.95, None, 1.6]),
        "free final time": (dmoc.OptimalControlProblem(knife, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                                       duration=(0.5, 3.0)), [0.1, 1.0, 0.0]),
        "path constraints, bounds (lane change)": (lane_change(30), [None, 3.4, 0.1, 0.0]),
        "holonomic (spherical pendulum)": (dmoc.OptimalControlProblem(
            sphere, 10, q_start=[np.sin(0.5), 0.0, -np.cos(0.5)],
            q_goal=[0.0, np.sin(0.5), None], v_goal=[None, 0.1, None]), [0.05, np.sin(0.5), None]),
    }


def _bits(value):
    return np.asarray(value, dtype=float).view(np.int64)


def _same(a, b):
    """The same bits and stats (but times, and whether a solver was reused: dmoc's choice
    and the explicit option may keep different solvers)."""
    for name in ("x", "lam_x", "lam_g", "cost"):
        np.testing.assert_array_equal(_bits(getattr(a, name)), _bits(getattr(b, name)), err_msg=name)
    assert a.status == b.status and a.message == b.message
    kept = [k for k in a.stats if not k.endswith("_time") and k != "solver_reused"]
    assert {k: a.stats[k] for k in kept} == {k: b.stats[k] for k in kept}


def _chosen(problem, result, options=None):
    """`data_options` at the start point of a solve of `problem` from `result` (None: cold)."""
    T = problem.transcription
    x0 = start_point(problem, result)[0] / T.x_scale
    return ipopt.data_options(T, x0, options or {})


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", list(_problems()))
def test_without_ipopts_scaling_the_same_bits_as_with_it(name, mode):
    """A first solve and two warm re-solves with new goals: x, lam_x, lam_g, cost, status
    and every stat but times are those of IPOPT's gradient-based scaling. "none" is chosen
    for every first solve and for the re-solves of the benchmarks' problems (the knife
    edge, the rolling disk); the lane change's warm starts have entries above 100, which
    IPOPT scales, and dmoc leaves its scaling on there."""
    problem, goal = _problems()[name]
    ours, own = solve(problem, **mode), solve(problem, options=GRADIENT_BASED, **mode)
    _same(ours, own)
    assert "nlp_scaling_method" in _chosen(problem, None)
    chosen = []
    for step in (1.0, -1.0):
        moved = problem.with_boundary(q_goal=[None if g is None else p + step * (g - p)
                                              for g, p in zip(goal, problem.q_goal)])
        chosen.append("nlp_scaling_method" in _chosen(moved, ours))
        ours, own = solve(moved, guess=ours, **mode), solve(moved, guess=own, options=GRADIENT_BASED, **mode)
        assert ours.stats["warm_start"]
        _same(ours, own)
    if name in ("knife edge", "rolling disk"):
        assert all(chosen)
    if name.endswith("(lane change)"):
        assert not all(chosen)


@pytest.mark.parametrize("name", ["knife edge", "path constraints, bounds (lane change)"])
def test_the_figures_are_the_largest_entries_of_the_dense_derivatives(name):
    """At the default start point and at random points: the largest |entry| of grad f and
    of the Jacobian from CasADi's dense AD of the NLP's expressions (to round-off); the
    choice follows IPOPT's rule (both at most 100; none of the points is within round-off
    of 100)."""
    problem = _problems()[name][0]
    T = problem.transcription
    nlp = T.nlp
    dense = ca.Function("dense", [nlp["x"], nlp["p"]],
                        [ca.densify(ca.gradient(nlp["f"], nlp["x"])), ca.densify(ca.jacobian(nlp["g"], nlp["x"]))])
    figures = ipopt._start_figures(T, False)
    rng = np.random.default_rng(3)
    points = [start_point(problem, None)[0] / T.x_scale] + [rng.normal(size=T.x_layout.size) for _ in range(5)]
    for x0 in points:
        gradient, jacobian = (np.abs(np.array(m)) for m in dense(x0, T.p))
        _, largest_jacobian, largest_gradient, total = (float(v) for v in figures(np.concatenate([x0, T.p])))
        # to round-off: the dense AD takes other operations than the NLP's assembled terms
        assert np.isclose(largest_jacobian, jacobian.max(), rtol=1e-12, atol=0.0)
        assert np.isclose(largest_gradient, gradient.max(), rtol=1e-12, atol=0.0)
        assert np.isclose(total, jacobian.sum() + gradient.sum(), rtol=1e-12)
        chosen = "nlp_scaling_method" in ipopt.data_options(T, x0, {})
        assert chosen == (jacobian.max() <= 100.0 and gradient.max() <= 100.0)


def test_two_evaluations_fewer_and_the_users_scaling_options_kept():
    """Without the scaling IPOPT calls grad f and the Jacobian once less per solve; any
    ``nlp_scaling_*`` option of the user's leaves IPOPT's scaling on (here a cut-off of 1,
    under which IPOPT scales the rows: other iterates); a NaN or an infinite entry at the
    start point leaves it to IPOPT too."""
    problem = dmoc.problems.knife_edge_parking(12)
    T = problem.transcription
    calls = []
    for options in ({}, GRADIENT_BASED):
        solve(problem, options=options)
        merged = {**ipopt.data_options(T, start_point(problem, None)[0] / T.x_scale, options),
                  **ipopt.start_options(False), **options}
        st = ipopt.solver(T, merged, expand=False, reuse=True, report=False)[0].stats()
        calls.append((st["n_call_nlp_grad_f"], st["n_call_nlp_jac_g"]))
    assert calls[0] == (calls[1][0] - 1, calls[1][1] - 1)
    x0 = start_point(problem, None)[0] / T.x_scale
    assert ipopt.data_options(T, x0, {}) == {"nlp_scaling_method": "none"}
    for options in ({"nlp_scaling_max_gradient": 1.0}, {"nlp_scaling_min_value": 1e-6}):
        assert ipopt.data_options(T, x0, options) == {}
    cut = solve(problem, options={"nlp_scaling_max_gradient": 1.0})
    assert cut.success and not np.array_equal(cut.x, solve(problem).x)
    for bad in (np.nan, np.inf):
        x = x0.copy()
        x[T.x_layout.slice("u")] = bad
        assert "nlp_scaling_method" not in ipopt.data_options(T, x, {})
