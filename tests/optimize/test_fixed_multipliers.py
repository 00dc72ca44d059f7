"""The bound multipliers of the fixed entries of x (the given boundary data), which IPOPT
leaves zero under dmoc's ``fixed_variable_treatment`` "make_parameter_nodual" and
`dmoc.optimal_control.solver.fixed_multipliers.FixedMultipliers` computes after the solve, are
the bits IPOPT's own "make_parameter" gives (benchmarks/peers.py resolve times the re-solves).

Oracles: IPOPT itself, the same solves with ``fixed_variable_treatment`` "make_parameter"
given in `options` (IPOPT forms the multipliers in its ``TNLPAdapter``, not in dmoc), and
the stationarity of the Lagrangian written out below with a dense Jacobian.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc._util.compiled import compiler
from dmoc._util.deferred import Pending
from dmoc.optimal_control.solver import ipopt
from dmoc.drivers.mpc import shifted
from dmoc.optimal_control import solve

from .._helpers import lagrangian_gradient

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
from lane_change_problem import lane_change  # noqa: E402

IPOPT_OWN = {"fixed_variable_treatment": "make_parameter"}
# dmoc's default treatment given explicitly: warm re-solves stay with IPOPT (without
# `options` an equality-constrained one is Newton's, `dmoc.optimal_control.solver.newton_kkt`)
NODUAL = {"fixed_variable_treatment": "make_parameter_nodual"}
MODES = [{}, {"expand": True}, pytest.param({"jit": True}, marks=pytest.mark.skipif(
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
    for name in ("x", "lam_x", "lam_g", "cost"):
        np.testing.assert_array_equal(_bits(getattr(a, name)), _bits(getattr(b, name)), err_msg=name)
    assert a.status == b.status and a.message == b.message
    # every stat but times and whether the solver came from the cache, which depends on
    # the tests run before (a solver of the same structure and options left there)
    how = ("solver_reused", "compiled")    # how the solve ran (the compiled NLP gives the same bits)
    assert {k: v for k, v in a.stats.items() if not k.endswith("_time") and k not in how} == \
        {k: v for k, v in b.stats.items() if not k.endswith("_time") and k not in how}


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", list(_problems()))
def test_the_fixed_entries_multipliers_are_ipopts_own_bit_for_bit(name, mode):
    """A first solve and two warm re-solves with new goals (the previous optimum as the
    guess): x, lam_x, lam_g, cost, status and every stat but times are those of IPOPT's
    make_parameter, the same iterations, and the fixed entries' multipliers are not all
    zero (they are what was computed)."""
    problem, goal = _problems()[name]
    ours, own = solve(problem, **mode), solve(problem, options=IPOPT_OWN, **mode)
    _same(ours, own)
    fixed = problem.transcription.lbx == problem.transcription.ubx
    assert fixed.any() and np.any(ours.lam_x[fixed] != 0.0)
    unread = ours
    for step in (1.0, -1.0):
        moved = problem.with_boundary(q_goal=[None if g is None else p + step * (g - p)
                                              for g, p in zip(goal, problem.q_goal)])
        ours, own = (solve(moved, guess=ours, options=NODUAL, **mode),
                     solve(moved, guess=own, options=IPOPT_OWN, **mode))
        unread = solve(moved, guess=unread, options=NODUAL, **mode)
        assert ours.stats["warm_start"] and unread.stats["warm_start"]
        _same(ours, own)
    # warm-started from results whose fixed multipliers were never made: the same chain
    assert isinstance(vars(unread)["lam_x"], Pending)
    _same(unread, own)


def test_a_stopped_solve_and_a_shifted_warm_start_keep_ipopts_bits():
    """At the last iterate of a solve stopped by max_iter, and through an MPC shift of the
    optimum (`dmoc.drivers.mpc.shifted`) used as the next guess."""
    problem = dmoc.problems.knife_edge_parking(20)
    stopped = solve(problem, options={"max_iter": 3}, throw=False)
    _same(stopped, solve(problem, options={"max_iter": 3, **IPOPT_OWN}, throw=False))
    assert not stopped.success
    ours, own = solve(problem), solve(problem, options=IPOPT_OWN)
    later = problem.with_boundary(q_start=problem.transcription.configurations(ours.x)[1])
    _same(solve(later, guess=shifted(ours, problem), options=NODUAL),
          solve(later, guess=shifted(own, problem), options=IPOPT_OWN))


@pytest.mark.parametrize("name", list(_problems()))
def test_the_fixed_entries_multipliers_make_the_lagrangian_stationary(name):
    """-(df/dx_i + sum_j lam_g_j dg_j/dx_i) at the fixed entries, in the scaled NLP IPOPT
    solves, from CasADi's dense Jacobian of the NLP's expressions (not the Functions
    IPOPT evaluates), agrees with result.lam_x to round-off."""
    problem = _problems()[name][0]
    result = solve(problem)
    T = problem.transcription
    D, R = T.x_scale, T.g_scale
    stationary = -np.array(lagrangian_gradient(T)(result.x / D, T.p, result.lam_g / R)).ravel() / D
    fixed = T.lbx == T.ubx
    scale = max(1.0, np.max(np.abs(result.lam_x[fixed])))
    np.testing.assert_allclose(result.lam_x[fixed], stationary[fixed], rtol=0, atol=1e-12 * scale)


def test_ipopts_own_treatments_are_left_to_it():
    """Given another ``fixed_variable_treatment``, the solver computes nothing itself:
    make_parameter is IPOPT's own (the oracle above), make_constraint gives multipliers
    of the fixed entries within IPOPT's tolerance of the default's, and an explicit
    make_parameter_nodual is the default."""
    problem = dmoc.problems.knife_edge_parking(12)
    default = solve(problem)
    assert ipopt.DEFAULT_IPOPT_OPTIONS["fixed_variable_treatment"] == "make_parameter_nodual"
    _same(default, solve(problem, options={"fixed_variable_treatment": "make_parameter_nodual"}))
    constraint = solve(problem, options={"fixed_variable_treatment": "make_constraint"})
    fixed = problem.transcription.lbx == problem.transcription.ubx
    np.testing.assert_allclose(constraint.lam_x[fixed], default.lam_x[fixed], rtol=1e-6, atol=1e-8)


def test_a_warm_start_with_other_fixed_entries_reads_the_made_multipliers():
    """A goal entry set free (the same NLP, one fixed entry fewer) within finite state
    bounds, so that IPOPT takes a start for its bound multipliers: the guess's fixed
    multipliers are made and handed to IPOPT as that start, as IPOPT's own make_parameter
    result would hand them: the same bits (a start of zero, the multiplier not made, gives
    other iterates)."""
    knife = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    problem = dmoc.OptimalControlProblem(knife, 12, q_start=[0, 0, 0], q_goal=[0.0, 1.0, 0.3],
                                         state_bounds=([-2.0, -2.0, -0.5], [2.0, 2.0, 0.5]))
    freed = problem.with_boundary(q_goal=[0.0, 1.0, None])
    assert freed.structure == problem.structure
    assert (freed.transcription.lbx == freed.transcription.ubx).sum() < \
        (problem.transcription.lbx == problem.transcription.ubx).sum()
    ours, own = solve(problem), solve(problem, options=IPOPT_OWN)
    assert isinstance(vars(ours)["lam_x"], Pending)
    _same(solve(freed, guess=ours), solve(freed, guess=own, options=IPOPT_OWN))
