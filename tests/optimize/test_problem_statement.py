"""The problem is the user's statement and its transcription owns the NLP: the statement's
attributes are read-only, the transcription is built once and shared by the copies that
keep the NLP, the momentum treatment and the final time are values that declare what they
do, and dmoc's switches of `optimize` are keywords (the old `options` entries warn and
give the same solve).

Oracles: the sizes of the NLP counted here from the problem's data (n, N, m, the rows of
the residual), the closed-form step range T/N, and the solve by the keyword spelling
against the solve by the deprecated one (both from fresh solvers, hence the same IPOPT
run: equal x).
"""

import warnings

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.errors import DmocDeprecationWarning, InputError
from dmoc.optimal_control.statement.final_time import FixedFinalTime, FreeFinalTime
from dmoc.optimal_control.nlp.momenta import CarriedMomenta, SubstitutedMomenta
from dmoc.optimal_control.nlp.transcription import Transcription
from dmoc.problems import knife_edge_parking
from dmoc.systems import knife_edge

N = 10
START, GOAL = [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]


def problem(**extra):
    disc = dmoc.discretize(knife_edge(mass=1.0, inertia=1.0), 0.2)
    return dmoc.OptimalControlProblem(disc, N, q_start=START, q_goal=GOAL, **extra)


# --- read-only statement ------------------------------------------------------------------

@pytest.mark.parametrize("name, hint", [("q_goal", "with_boundary"), ("v_start", "with_boundary"),
                                        ("parameters", "with_parameters"), ("steps", "new OptimalControlProblem"),
                                        ("x_layout", "new OptimalControlProblem"),
                                        ("transcription", "new OptimalControlProblem")])
def test_assigning_an_attribute_raises_and_names_the_way_to_change_it(name, hint):
    ocp = problem()
    before = getattr(ocp, name)
    with pytest.raises(AttributeError, match=rf"`OptimalControlProblem\.{name}` is read-only.*{hint}"):
        setattr(ocp, name, None)
    with pytest.raises(AttributeError, match="cannot be deleted"):
        delattr(ocp, name)
    assert getattr(ocp, name) is before


def test_transcription_attributes_are_read_only():
    T = problem().transcription
    with pytest.raises(AttributeError, match=r"`Transcription\.lbx` is read-only.*with_boundary"):
        T.lbx = np.zeros(3)


@pytest.mark.parametrize("name", ["q_goal", "v_start", "lbx", "ubg", "p", "q_ref", "x_scale"])
def test_arrays_cannot_be_changed_in_place(name):
    ocp = problem()
    with pytest.raises(ValueError, match="read-only"):
        getattr(ocp, name)[0] = 5.0


def test_the_transcription_is_built_once_and_is_the_problems_nlp():
    ocp = problem()
    T = ocp.transcription
    assert isinstance(T, Transcription) and ocp.transcription is T
    for name in ("nlp", "separable", "x_layout", "p_layout", "g_layout", "dynamics_rows",
                 "x_scale", "g_scale", "lbx", "ubx", "lbg", "ubg", "p", "q_ref"):
        assert getattr(ocp, name) is getattr(T, name), name
    assert ocp.structure == T.structure
    x = np.arange(T.x_layout.size, dtype=float)
    np.testing.assert_array_equal(ocp.configurations(x), T.configurations(x))
    np.testing.assert_array_equal(ocp.momenta(x), T.momenta(x))


def test_the_statement_exposes_the_data_the_transcription_reads():
    """The user's costs and bounds are public: the running cost is |u|^2 by default."""
    ocp = problem(control_bounds=([-1.0, None], [2.0, None]))
    assert float(ocp.running_cost([0, 0, 0], [0, 0, 0], [3.0, 4.0], ca.DM(0, 1))) == 25.0
    assert ocp.terminal_cost is None and ocp.path_constraints is None
    np.testing.assert_array_equal(ocp.control_bounds[0], [-1.0, -np.inf])
    np.testing.assert_array_equal(ocp.control_bounds[1], [2.0, np.inf])
    assert ocp.velocity_rows == {"start": False, "goal": False}      # given zero velocities


# (q, v) at an end -> whether A(q) v = 0 is imposed there, by the rule of
# docs/stages/optimize.md written out: not when q and v are fully given (checked once), nor
# when v is given and zero (the rows vanish for every q); else imposed. On the knife edge
# A(q) v = v_x sin(theta) - v_y cos(theta): at theta = 0, (1, 0, 0) is allowed.
VELOCITY_ROWS = [
    ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], False),         # both fully given, v nonzero
    ([0.0, 1.0, 0.0], [0.0, 0.0, 0.0], False),         # both fully given, v zero
    ([0.0, 1.0, 0.0], [None, 0.0, 0.0], True),         # q given, v partly free
    ([0.0, None, 0.0], [1.0, 0.0, 0.0], True),         # q partly free, v given nonzero
    ([0.0, None, 0.0], [0.0, -0.0, 0.0], False),       # q partly free, v given zero (a signed one)
    ([0.0, None, 0.0], [0.0, 0.0, 0.3], True),         # only the turning rate nonzero
    ([0.0, None, 0.0], [None, 0.0, 0.0], True),        # both partly free
    ([None, None, None], [None, None, None], True),    # nothing given
]


@pytest.mark.parametrize("q, v, imposed", VELOCITY_ROWS)
def test_the_velocity_rows_follow_the_rule_at_each_end(q, v, imposed):
    """`velocity_rows` and the NLP's rows (m = 1 per end imposed), the start given by its
    velocity or by its momentum (then never, whatever the goal's), for a new problem and for `with_boundary`
    from a problem whose ends had the other answer."""
    disc = dmoc.discretize(knife_edge(mass=1.0, inertia=1.0), 0.2)

    def ocp(**data):
        return dmoc.OptimalControlProblem(disc, N, **data)
    rows = [{"start": s, "goal": g} for s, g in ((imposed, False), (False, imposed), (False, False),
                                                 (False, imposed))]
    made = [ocp(q_start=q, v_start=v, q_goal=GOAL), ocp(q_start=START, q_goal=q, v_goal=v),
            ocp(q_start=q, q_goal=GOAL, p_start=[1.0, 0.0, 0.0]),
            ocp(q_start=START, p_start=[1.0, 0.0, 0.0], q_goal=q, v_goal=v)]
    other = [None, 0.0, 0.0] if not imposed else [0.0, 0.0, 0.0]
    before = ocp(q_start=[0.0, None, 0.0], v_start=other, q_goal=[0.0, None, 0.0], v_goal=other)
    moved = [before.with_boundary(q_start=q, v_start=v), before.with_boundary(q_goal=q, v_goal=v)]
    kept = [{"start": imposed, "goal": not imposed}, {"start": not imposed, "goal": imposed}]
    for stated, expected in zip(made + moved, rows + kept):      # the other end keeps its rows
        assert stated.velocity_rows == expected, (q, v)
        for end in ("start", "goal"):
            assert stated.g_layout.numel(end + "_velocity") == int(expected[end]), (end, q, v)


def test_copies_share_the_nlp_and_carry_their_own_bounds():
    ocp = problem(parameters={"r": 1.0}, running_cost=lambda q, v, u, w: w["r"] * ca.sumsqr(u))
    moved = ocp.with_boundary(q_goal=[0.2, 1.0, 0.0])
    heavier = ocp.with_parameters(r=3.0)
    for copy in (moved, heavier):
        assert copy.transcription is not ocp.transcription
        assert copy.separable is ocp.separable and copy.x_layout is ocp.x_layout
    lay = ocp.x_layout
    assert lay.unpack(moved.lbx, "q")[0, N] == 0.2 and lay.unpack(ocp.lbx, "q")[0, N] == 0.0
    w = ocp.p_layout.slice("w")
    assert heavier.p[w].tolist() == [3.0] and ocp.p[w].tolist() == [1.0]
    freed = ocp.with_boundary(v_goal=[None, None, None])      # the velocity rows appear
    assert freed.separable is not ocp.separable and freed.g_layout.numel("goal_velocity") == 1


# --- the momentum treatment and the final time as values ---------------------------------

def test_momentum_treatments_declare_their_variables_and_rows():
    """Substituted: x's block "p" is p_0 alone and the residual's "right" rows are not
    imposed; carried: p_0 ... p_N and all rows. The NLPs differ by n N variables and rows
    and have the same optimum."""
    substituted, carried = problem(), problem(momenta="variables")
    S, C = substituted.momentum_treatment, carried.momentum_treatment
    assert isinstance(S, SubstitutedMomenta) and isinstance(C, CarriedMomenta)
    n, R = 3, substituted.residual
    assert substituted.x_layout.blocks["p"][1:] == (n, 1) and carried.x_layout.blocks["p"][1:] == (n, N + 1)
    assert "right" not in S.dynamics_rows.blocks and C.dynamics_rows.size == R.row_layout.size
    assert carried.x_layout.size - substituted.x_layout.size == n * N
    assert carried.g_layout.size - substituted.g_layout.size == n * N
    a, b = dmoc.optimize(substituted, check=False), dmoc.optimize(carried, check=False)
    assert a.cost == pytest.approx(b.cost, rel=1e-9)
    np.testing.assert_allclose(a.trajectory.p, b.trajectory.p, rtol=0, atol=1e-8)


def test_a_formulation_without_an_explicit_p1_carries_the_momenta():
    """The Hamiltonian (+) form (39) is explicit in q_{k+1}: "substituted" falls back."""
    system = dmoc.HamiltonianSystem(
        lambda q, p: ca.dot(p, p) / 2, 3, constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
        force=lambda q, p, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]), n_u=2)
    ocp = dmoc.OptimalControlProblem(dmoc.discretize(system, 0.2, "midpoint"), N, q_start=START,
                                     q_goal=GOAL, variant="+", momenta="substituted")
    assert isinstance(ocp.momentum_treatment, CarriedMomenta)
    assert ocp.x_layout.blocks["p"][1:] == (3, N + 1)


def test_final_time_values_say_where_h_lives_and_its_range():
    fixed, free = problem(), problem(duration=(1.0, 3.0))
    assert isinstance(fixed.final_time, FixedFinalTime) and not fixed.free_time and fixed.duration is None
    assert fixed.x_layout.numel("h") == 0 and fixed.p[fixed.p_layout.slice("h")].tolist() == [0.2]
    assert isinstance(free.final_time, FreeFinalTime) and free.free_time and free.duration == (1.0, 3.0)
    assert free.p_layout.numel("h") == 0
    h = free.x_layout.slice("h")
    assert free.lbx[h].tolist() == [1.0 / N] and free.ubx[h].tolist() == [3.0 / N]
    result = dmoc.optimize(free, check=False)
    assert 1.0 / N <= result.trajectory.h <= 3.0 / N
    assert result.trajectory.h == free.x_layout.unpack(result.x, "h")[0, 0]


# --- dmoc's switches as keywords -----------------------------------------------------------

@pytest.mark.parametrize("name, value", [("reuse_solver", False), ("expand", True)])
def test_switch_keyword_and_deprecated_option_give_the_same_solve(name, value):
    ocp = knife_edge_parking(N)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DmocDeprecationWarning)       # the keyword does not warn
        new = dmoc.optimize(ocp, **{"reuse_solver": False, name: value}, check=False)
    with pytest.warns(DmocDeprecationWarning, match=rf"options\['{name}'\].*`{name}={value!r}`"):
        old = dmoc.optimize(ocp, options={name: value},
                            **({} if name == "reuse_solver" else {"reuse_solver": False}), check=False)
    assert new.success and old.success and not new.stats["solver_reused"]
    np.testing.assert_array_equal(new.x, old.x)
    assert new.cost == old.cost and new.stats["iterations"] == old.stats["iterations"]


def test_both_spellings_take_the_same_solver():
    """With a default solver cached, `expand` in either spelling is another solver (a
    fresh build, then the cached one), and `reuse_solver=False` in either spelling builds
    anew although one is cached."""
    ocp = knife_edge_parking(N)
    dmoc.clear_caches("solvers")
    dmoc.optimize(ocp, check=False)
    with pytest.warns(DmocDeprecationWarning, match="expand=True"):
        expanded = dmoc.optimize(ocp, options={"expand": True}, check=False)
    again = dmoc.optimize(ocp, expand=True, check=False)
    assert not expanded.stats["solver_reused"] and again.stats["solver_reused"]
    with pytest.warns(DmocDeprecationWarning, match="reuse_solver=False"):
        assert not dmoc.optimize(ocp, options={"reuse_solver": False}, check=False).stats["solver_reused"]
    assert not dmoc.optimize(ocp, reuse_solver=False, check=False).stats["solver_reused"]
    assert dmoc.optimize(ocp, check=False).stats["solver_reused"]


def test_linear_solver_report_keyword_and_deprecated_option():
    ocp = knife_edge_parking(N)
    new = dmoc.optimize(ocp, reuse_solver=False, linear_solver_report=True, check=False)
    with pytest.warns(DmocDeprecationWarning, match="linear_solver_report=True"):
        old = dmoc.optimize(ocp, reuse_solver=False, options={"linear_solver_report": True}, check=False)
    assert new.stats["linear_solver"] == old.stats["linear_solver"]
    assert new.stats["linear_solver"]["factorizations"] > 0
    assert "linear_solver" not in dmoc.optimize(ocp, check=False).stats


def test_reuse_solver_keeps_its_meaning():
    ocp = knife_edge_parking(N)
    dmoc.optimize(ocp, check=False)
    assert dmoc.optimize(ocp, check=False).stats["solver_reused"]
    assert not dmoc.optimize(ocp, reuse_solver=False, check=False).stats["solver_reused"]


def test_switches_are_checked_and_not_given_twice():
    ocp = knife_edge_parking(N)
    with pytest.raises(TypeError, match="`expand` must be True or False"):
        dmoc.optimize(ocp, expand="no")
    with pytest.raises(InputError, match="`reuse_solver` is given twice"), \
            pytest.warns(DmocDeprecationWarning):
        dmoc.optimize(ocp, reuse_solver=False, options={"reuse_solver": True})
