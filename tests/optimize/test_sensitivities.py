"""Parametric sensitivities of an optimum from its KKT system (`dmoc.sensitivities`).

Oracles: central differences of re-solves with the data moved (`with_boundary`,
`with_parameters`, warm-started, IPOPT to tol 1e-12), on a knife edge whose bounds are
all inactive, on one whose control bound is active on three steps and on one whose path
constraint (a turning rate) is active at two midpoints (the data moved by 1e-4, far from
a change of the active set); the envelope theorem: dJ/dq_goal equals minus
the multipliers of the fixed entries q_N, and dJ/dr the derivative of the NLP's cost in r
at the fixed optimal x.
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.drivers import kkt_sensitivity
from dmoc.optimal_control.nlp import kkt_matrix
from dmoc.errors import InputError

OPTIONS = {"tol": 1e-12}
DELTA = 1e-4


def problem(control_bounds=None, path_constraints=None):
    """The knife edge on 10 steps to a turned goal, cost u0^2 + r u1^2."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.2)
    return dmoc.OptimalControlProblem(
        disc, 10, q_start=[0, 0, 0], q_goal=[0.5, 1.0, 0.3], parameters={"r": 2.0},
        running_cost=lambda q, v, u, w: u[0] ** 2 + w["r"] * u[1] ** 2, control_bounds=control_bounds,
        path_constraints=path_constraints)


@pytest.fixture(params=["ldl", "qr"])
def method(request, monkeypatch):
    """(name, methods used) of each way of solving the KKT system first: the regularized
    LDL^T refined against the exact matrix (QR_COST infinite), or the exact matrix's sparse
    QR (QR_COST 0); the layouts, which hold the choice, made anew before and after; the
    methods `solve_kkt` called, in order, recorded in the list."""
    monkeypatch.setattr(kkt_matrix, "QR_COST", np.inf if request.param == "ldl" else 0.0)
    used, solution = [], kkt_sensitivity.kkt_solution
    monkeypatch.setattr(kkt_sensitivity, "kkt_solution", lambda *args: used.append(args[-1]) or solution(*args))
    dmoc.clear_caches("kkt_layouts")
    yield request.param, used
    dmoc.clear_caches("kkt_layouts")


def moved(problem, name, value):
    return problem.with_parameters(r=value) if name == "r" else problem.with_boundary(**{name: value})


def differences(problem, result, name):
    """Central differences of (cost, q, u) of re-solves, one column per entry of `name`."""
    value = np.atleast_1d(problem.parameter_values["r"] if name == "r" else getattr(problem, name))
    columns = []
    for i in range(value.size):
        ends = []
        for sign in (1, -1):
            v = value.copy()
            v[i] += sign * DELTA
            r = dmoc.optimize(moved(problem, name, v if name != "r" else v[0]), guess=result, options=OPTIONS)
            ends.append((r.cost, r.trajectory.q, r.trajectory.u))
        columns.append([(a - b) / (2 * DELTA) for a, b in zip(*ends)])
    return [np.stack(c, axis=-1) for c in zip(*columns)]


def assert_relative(actual, expected, rtol=1e-6):
    scale = np.abs(expected).max()
    assert np.abs(actual - expected).max() <= rtol * scale, (np.abs(actual - expected).max(), scale)


@pytest.mark.parametrize("case", ["inactive bounds", "active control bound", "active path constraint"])
def test_sensitivities_equal_differences_of_re_solves(case, method):
    bounded, path = case == "active control bound", case == "active path constraint"
    p = problem(([-10, -3], [10, 10]) if bounded else None,
                (lambda q, v, u, w: v[2] - 1.2) if path else None)      # turning rate <= 1.2
    result = dmoc.optimize(p, options=OPTIONS)
    names = ("q_goal", "r", "q_start") if bounded else ("q_goal", "r")
    d = dmoc.sensitivities(p, result, wrt=names)
    on_bound = np.isclose(result.trajectory.u[:, 1], -3.0, atol=1e-7)
    assert on_bound.sum() == (3 if bounded else 0)
    assert d.active["x"].size == 12 + on_bound.sum()      # q_0, q_N, v_start, v_goal and the bound
    # dynamics, start, goal, and the held rate: at two midpoints and at the knot between
    # them, whose velocity is their mean (dependent rows: a singular KKT matrix unshifted)
    assert d.active["g"].size == 46 + (3 if path else 0)
    for name in names:
        cost, q, u = differences(p, result, name)
        shape = (3,) if name != "r" else (1,)
        assert_relative(d.cost[name].reshape(shape), cost)
        assert_relative(d.q[name].reshape(11, 3, -1), q)
        assert_relative(d.u[name].reshape(10, 2, -1), u)
        np.testing.assert_allclose(d.u[name].reshape(10, 2, -1)[on_bound, 1], 0.0, atol=1e-12)
    assert method[1] == [method[0]]


def test_cost_derivatives_are_the_multiplier_identities():
    """Envelope theorem: dJ/dq_goal = -lam_x at the fixed q_N (q_ref = q_start does not
    move with the goal); dJ/dr = df/dr at the fixed optimal x."""
    p = problem(([-10, -3], [10, 10]))
    result = dmoc.optimize(p, options=OPTIONS)
    d = dmoc.sensitivities(p, result, wrt=("q_goal", "r"))
    T = p.transcription
    q_N = T.x_layout.unpack(result.lam_x, "q")[:, -1]
    np.testing.assert_allclose(d.cost["q_goal"], -q_N, rtol=1e-9)
    x = result.x / T.x_scale
    up, down = (moved(p, "r", 2.0 + s * DELTA).transcription.p for s in (1, -1))
    explicit = (T.separable.values(x, up)[0] - T.separable.values(x, down)[0]) / (2 * DELTA)
    np.testing.assert_allclose(d.cost["r"], explicit, rtol=1e-9)


def test_bad_requests_are_named():
    p = problem()
    result = dmoc.optimize(p)
    with pytest.raises(InputError, match=r"`wrt` must name boundary data or parameters of the problem \(.*'r'\); got 'mass'"):
        dmoc.sensitivities(p, result, wrt="mass")
    with pytest.raises(InputError, match=r"`wrt` names 'p_start', which this problem does not give"):
        dmoc.sensitivities(p, result, wrt="p_start")
    with pytest.raises(InputError, match=r"`wrt` names 'v_start', but this problem starts from p_start"):
        started = p.with_boundary(p_start=[0.0, 0.0, 0.0])
        dmoc.sensitivities(started, dmoc.optimize(started), wrt="v_start")
    free = p.with_boundary(q_goal=[0.5, 1.0, None])
    with pytest.raises(InputError, match=r"`wrt` names 'v_goal', whose change gives this problem another NLP"):
        dmoc.sensitivities(free, dmoc.optimize(free), wrt="v_goal")
    other = dmoc.optimize(dmoc.problems.knife_edge_parking(20))
    with pytest.raises(InputError, match=r"`result` must be an optimum of `problem`"):
        dmoc.sensitivities(p, other, wrt="q_goal")


def test_a_free_goal_entry_has_zero_derivatives_and_the_others_match_re_solves():
    p = problem().with_boundary(q_goal=[0.5, 1.0, None])
    result = dmoc.optimize(p, options=OPTIONS)
    d = dmoc.sensitivities(p, result, wrt="q_goal")
    assert d.cost["q_goal"][2] == 0 and not d.q["q_goal"][..., 2].any()
    moved = dmoc.optimize(p.with_boundary(q_goal=[0.5 + DELTA, 1.0, None]), guess=result, options=OPTIONS)
    back = dmoc.optimize(p.with_boundary(q_goal=[0.5 - DELTA, 1.0, None]), guess=result, options=OPTIONS)
    assert_relative(d.q["q_goal"][..., 0], (moved.trajectory.q - back.trajectory.q) / (2 * DELTA))


@pytest.mark.parametrize("case", ["active control bound", "dependent active rows"])
def test_the_kkt_solution_equals_a_dense_solve_of_the_kkt_system(case, method):
    """The matrix gathered from the solver's derivatives, its refined LDL^T (accepted: each
    column's backward error within BACKWARD_ERROR) or its sparse QR, against the KKT
    system written here from the NLP's expressions (CasADi's hessian and jacobian of
    `transcription.nlp`, the active set read off the bounds) and solved densely by least
    squares: its minimum-norm multipliers of the dependent rows (the turning rate held at
    two midpoints and at the knot between them) leave dx unique."""
    p = problem(([-10, -3], [10, 10]), None) if case == "active control bound" else \
        problem(None, lambda q, v, u, w: v[2] - 1.2)
    result = dmoc.optimize(p, options=OPTIONS)
    d = dmoc.sensitivities(p, result, wrt="q_goal")
    T = p.transcription
    x, p_value, f, g = (T.nlp[k] for k in ("x", "p", "f", "g"))
    x_value, lam = result.x / T.x_scale, result.lam_g / T.g_scale
    at = ca.Function("at", [x, p_value], [ca.hessian(f + ca.dot(lam, g), x)[0], ca.jacobian(g, x), g])
    H, J, g_value = (np.array(m) for m in at(x_value, T.p))
    lbx, ubx = T.lbx / T.x_scale, T.ubx / T.x_scale
    held = np.flatnonzero((lbx == ubx) | np.isclose(x_value, lbx, atol=1e-7) | np.isclose(x_value, ubx, atol=1e-7))
    lbg, ubg = T.scaled_g_bounds
    rows = np.flatnonzero((lbg == ubg) | np.isclose(g_value.ravel(), ubg, atol=1e-7))
    assert rows.size - np.linalg.matrix_rank(J[rows]) == (1 if case == "dependent active rows" else 0)
    E = np.eye(x_value.size)[held]
    K = np.block([[H, J[rows].T, E.T], [J[rows], np.zeros((rows.size, rows.size + held.size))],
                  [E, np.zeros((held.size, rows.size + held.size))]])
    q_N = T.x_layout.slice("q").start + 10 * 3 + np.arange(3)      # q_goal fixes q_N (q_ref = q_start)
    rhs = np.zeros((K.shape[0], 3))
    rhs[x_value.size + rows.size + np.searchsorted(held, q_N), range(3)] = 1 / T.x_scale[q_N]
    dx = np.linalg.lstsq(K, rhs, rcond=None)[0][:x_value.size]
    assert_relative(d.x["q_goal"] / T.x_scale[:, None], dx, rtol=1e-8)
    assert method[1] == [method[0]]


def test_a_singular_kkt_matrix_is_refused_naming_it(method):
    """Without a running cost every feasible trajectory is optimal: the Lagrangian's Hessian
    is zero (so are the multipliers) and the controls left free by the dynamics are a null
    direction of the KKT matrix, which is refused by name, not solved into numbers."""
    p = dmoc.OptimalControlProblem(dmoc.discretize(dmoc.systems.knife_edge(), 0.2), 10, q_start=[0, 0, 0],
                                   q_goal=[0.5, 1.0, 0.3], running_cost=lambda q, v, u: 0 * u[0])
    result = dmoc.optimize(p)
    assert result.cost == 0 and np.abs(result.lam_g).max() < 1e-8
    with pytest.raises(InputError, match=r"the optimum's KKT matrix \(the Lagrangian's Hessian with the active "
                                         r"constraints' Jacobian\) is singular: .* not strict"):
        dmoc.sensitivities(p, result, wrt="q_goal")
    assert method[1] == (["ldl", "qr"] if method[0] == "ldl" else ["qr"])     # the LDL^T's refinement stalls
