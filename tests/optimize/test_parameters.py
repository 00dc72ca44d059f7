"""Problem parameters (cost weights, obstacle data) are solver inputs: a problem with
parameters solves like the same problem with the values written into its callables, and
`with_parameters` re-solves with new values on the same NLP and solver.

Oracle: the problem built anew with the values baked into plain callables (no
parameters), solved by a fresh solver.
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.errors import InputError, InputTypeError
from dmoc.systems import knife_edge

N, H = 30, 0.1
START, GOAL = [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]


def disc():
    return dmoc.discretize(knife_edge(mass=1.0, inertia=1.0), H)


def weighted(r):
    return lambda q, v, u: u[0] ** 2 + r * u[1] ** 2


def parametric(**extra):
    return dmoc.OptimalControlProblem(disc(), N, q_start=START, q_goal=GOAL, parameters={"r": 4.0},
                                      running_cost=lambda q, v, u, w: u[0] ** 2 + w["r"] * u[1] ** 2,
                                      **extra)


def assert_same_optimum(result, reference):
    assert result.success and reference.success
    assert result.cost == pytest.approx(reference.cost, rel=1e-10)
    np.testing.assert_allclose(result.trajectory.q, reference.trajectory.q, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.trajectory.u, reference.trajectory.u, rtol=0, atol=1e-7)


def test_weight_as_parameter_equals_the_weight_written_in():
    baked = dmoc.OptimalControlProblem(disc(), N, q_start=START, q_goal=GOAL, running_cost=weighted(4.0))
    assert_same_optimum(dmoc.optimize(parametric()), dmoc.optimize(baked))


def test_new_weight_reuses_the_solver_and_matches_a_fresh_problem():
    problem = parametric()
    first = dmoc.optimize(problem)
    lighter = problem.with_parameters(r=0.25)
    assert lighter.structure == problem.structure and lighter.nlp is problem.nlp
    np.testing.assert_array_equal(problem.parameter_values["r"], [4.0])      # untouched
    again = dmoc.optimize(lighter)
    assert again.stats["solver_reused"] and again.stats["build_time"] == 0.0
    baked = dmoc.OptimalControlProblem(disc(), N, q_start=START, q_goal=GOAL,
                                       running_cost=weighted(0.25))
    reference = dmoc.optimize(baked, reuse_solver=False)
    assert_same_optimum(again, reference)
    assert abs(again.cost - first.cost) > 1e-3          # the weight did change the problem
    warm = dmoc.optimize(lighter, guess=first)
    assert warm.stats["warm_start"] and abs(warm.cost - reference.cost) <= 1e-9 * reference.cost


def obstacle(q, v, u, w):
    """rho^2 - |(x, y) - c|^2 <= 0: stay outside the disc of radius rho around c."""
    return w["rho"] ** 2 - ca.sumsqr(q[:2] - w["c"])


def test_obstacle_data_as_parameters_move_the_obstacle():
    problem = dmoc.OptimalControlProblem(disc(), N, q_start=START, q_goal=GOAL, path_constraints=obstacle,
                                         parameters={"c": [-0.1, 0.5], "rho": 0.2})
    moved = problem.with_parameters(c=[0.1, 0.5])
    for case, c in ((problem, [-0.1, 0.5]), (moved, [0.1, 0.5])):
        result = dmoc.optimize(case, check=False)
        baked = dmoc.OptimalControlProblem(
            disc(), N, q_start=START, q_goal=GOAL,
            path_constraints=lambda q, v, u, c=c: 0.2 ** 2 - ca.sumsqr(q[:2] - ca.DM(c)))
        assert_same_optimum(result, dmoc.optimize(baked, check=False))
        midpoints = (result.trajectory.q[1:, :2] + result.trajectory.q[:-1, :2]) / 2
        assert np.min(np.linalg.norm(midpoints - c, axis=1)) >= 0.2 - 1e-9


def test_terminal_cost_weight_as_parameter():
    def problem_with(terminal, **extra):
        return dmoc.OptimalControlProblem(disc(), N, q_start=START, q_goal=[None, 1.0, 0.0],
                                          terminal_cost=terminal, **extra)
    soft = problem_with(lambda q, v, w: w["k"] * (q[0] - 0.3) ** 2, parameters={"k": 1.0})
    for k in (1.0, 100.0):
        result = dmoc.optimize(soft.with_parameters(k=k))
        reference = dmoc.optimize(problem_with(lambda q, v, k=k: k * (q[0] - 0.3) ** 2))
        assert_same_optimum(result, reference)
    stiff = dmoc.optimize(soft.with_parameters(k=100.0)).trajectory.q[-1, 0]
    loose = dmoc.optimize(soft).trajectory.q[-1, 0]
    assert abs(stiff - 0.3) < abs(loose - 0.3)


@pytest.mark.parametrize("parameters, error, match", [
    ([1.0], InputTypeError, "`parameters` must be a dict"),
    ({"2r": 1.0}, InputError, "identifiers"),
    ({"r": np.nan}, InputError, r"parameters\['r'\]` must be finite"),
    ({"r": [[1.0, 2.0]]}, InputError, r"parameters\['r'\]` must be a scalar or shape"),
    ({"r": "heavy"}, InputTypeError, r"parameters\['r'\]"),
])
def test_bad_parameters_are_refused(parameters, error, match):
    with pytest.raises(error, match=match):
        dmoc.OptimalControlProblem(disc(), 5, q_start=START, q_goal=GOAL, parameters=parameters,
                                   running_cost=lambda q, v, u, w: ca.sumsqr(u))


def test_bad_new_values_are_refused():
    problem = parametric()
    with pytest.raises(InputError, match="unknown keys"):
        problem.with_parameters(weight=1.0)
    with pytest.raises(InputError, match=r"parameters\['r'\]` must be shape \(1,\)"):
        problem.with_parameters(r=[1.0, 2.0])


@pytest.mark.parametrize("given, callables", [
    ({"r": 1.0}, {"running_cost": lambda q, v, u: ca.sumsqr(u)}),
    ({"r": 1.0}, {"running_cost": lambda q, v, u, w: ca.sumsqr(u), "terminal_cost": lambda q, v: 0}),
    ({"r": 1.0}, {"running_cost": lambda q, v, u, w: ca.sumsqr(u), "path_constraints": lambda q, v, u: q[0]}),
    (None, {"running_cost": lambda q, v, u, w: ca.sumsqr(u)}),
])
def test_a_callable_with_the_wrong_arguments_is_named(given, callables):
    """With `parameters` every cost and path callable takes w last; without, it must not."""
    name = list(callables)[-1]
    with pytest.raises(InputTypeError, match=f"`{name}` must take .* (with|without) `parameters`"):
        dmoc.OptimalControlProblem(disc(), 5, q_start=START, q_goal=GOAL, parameters=given, **callables)


def test_new_values_for_a_problem_without_parameters():
    problem = dmoc.OptimalControlProblem(disc(), 5, q_start=START, q_goal=GOAL)
    with pytest.raises(InputError, match="this problem has no parameters"):
        problem.with_parameters(r=1.0)


def test_parameter_values_are_copies():
    problem = parametric()
    problem.parameter_values["r"][0] = 99.0
    assert problem.parameter_values["r"][0] == 4.0
    assert problem.p[problem.p_layout.slice("w")][0] == 4.0


def test_the_stored_values_cannot_be_changed_in_place():
    """A problem's p is formed of its parameter values once and kept by `with_boundary`:
    the stored values are read-only, so no write can leave p behind them (a caller's own
    array given as a value stays writeable: it was copied)."""
    given = np.array([4.0])
    problem = dmoc.OptimalControlProblem(disc(), 5, q_start=START, q_goal=GOAL, parameters={"r": given},
                                         running_cost=lambda q, v, u, w: w["r"] * ca.sumsqr(u))
    given[0] = 7.0
    for stored in (problem.parameters, problem.with_parameters(r=5.0).parameters):
        with pytest.raises(ValueError, match="read-only"):
            stored.values["r"][0] = 99.0
    moved = problem.with_boundary(q_goal=[0.1, 1.0, 0.0])
    assert moved.p[moved.p_layout.slice("w")][0] == problem.parameter_values["r"][0] == 4.0


def test_a_cost_with_a_default_for_w_is_accepted_without_parameters():
    problem = dmoc.OptimalControlProblem(disc(), 5, q_start=START, q_goal=GOAL,
                                         running_cost=lambda q, v, u, w=None: ca.sumsqr(u))
    assert dmoc.optimize(problem, check=False).success


def test_discrete_cost_takes_a_plain_callable():
    """`Discretization.discrete_cost` accepts the callable (q, v, u) it took before
    parameters existed: midpoint C_d = h |u|^2 for the running cost |u|^2."""
    C_d = disc().discrete_cost(lambda q, v, u: ca.sumsqr(u))
    u = np.array([0.3, -0.4])
    value = float(C_d(q0=[0, 0, 0], q1=[0.1, 0, 0], s=np.zeros(0), u=u, h=H, w=np.zeros(0))["C_d"])
    assert value == pytest.approx(H * 0.25, rel=1e-15)
    with pytest.raises(TypeError, match="`running_cost` must be a callable"):
        disc().discrete_cost(3)


def test_messages_write_a_path_row_with_the_names_of_its_symbols():
    """`row_texts`: the coordinates, their velocities (v_<name>), the controls and the
    parameters (a block of two entries as c_0, c_1) by name, a long row cut to the width."""
    from dmoc.optimal_control.statement.parameters import row_texts
    problem = dmoc.OptimalControlProblem(
        disc(), N, q_start=START, q_goal=GOAL, parameters={"c": [-0.1, 0.5], "rho": 0.2},
        path_constraints=lambda q, v, u, w: ca.vertcat(
            obstacle(q, v, u, w), v[2] - 2 * u[1], ca.sumsqr(ca.vertcat(*[q[0] ** k for k in range(1, 30)]))))
    texts = row_texts(problem.path_constraints, problem.disc.system, problem.parameters.layout)
    assert texts[:2] == ("(sq(rho)-(sq((x-c_0))+sq((y-c_1))))", "(v_theta-(2.*torque))")
    assert len(texts[2]) == 72 and texts[2].endswith("...")
