"""What the raw IPOPT solve reads back from a solve is what IPOPT computed: the packed call
(one stacked input and output vector, `dmoc.optimal_control.solver.ipopt.PackedSolver`) returns exactly
the outputs and statistics of calling the nlpsol itself, and the cost and most violated
row that `solve` takes from IPOPT's own last f and g are those of the NLP evaluated anew
at the returned x.

Oracles: the nlpsol called directly with the same inputs (a separate code path, the same
IPOPT: bitwise equal); the NLP's (f, g) Function (`SeparableNLP.values`) at the returned
x, and `most_violated` of that g. The fallback, where x was moved onto a bound after
IPOPT's last f and g, is held by tests/optimize/test_scaling.py (relaxed bounds).
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
import dmoc.problems
from dmoc.optimal_control.solver import ipopt
from dmoc.optimal_control.solver.guess import start_point
from dmoc.drivers.mpc import shifted
from dmoc.optimal_control.solver.solving import most_violated, solve, trajectory_from_x
from dmoc.principle.trajectory import Trajectory


def _inputs(problem, guess=None):
    """The scaled inputs of the nlpsol, as `solve` forms them."""
    T = problem.transcription
    x0, lam_x0, lam_g0 = start_point(problem, guess)
    D, R = T.x_scale, T.g_scale
    return dict(x0=x0 / D, p=T.p, lam_x0=lam_x0 * D, lam_g0=lam_g0 / R, lbx=T.lbx / D,
                ubx=T.ubx / D, lbg=T.lbg * R, ubg=T.ubg * R)


@pytest.mark.parametrize("warm", [False, True])
def test_the_packed_call_returns_what_the_nlpsol_returns(warm):
    problem = dmoc.problems.knife_edge_parking(12)
    moved = problem.with_boundary(q_goal=[0.1, 1.1, 0.1])
    guess = solve(problem) if warm else None
    packed, reused, _ = ipopt.solver(
        moved.transcription, {"warm_start_init_point": "yes" if warm else "no"},
        expand=False, reuse=False, report=False)
    assert not reused
    inputs = _inputs(moved, guess)
    sol = packed(**inputs)
    packed_stats = packed.stats()
    direct = {k: np.array(v).ravel() for k, v in packed.nlpsol(**inputs).items()}
    direct_stats = packed.nlpsol.stats()
    for name in ("x", "f", "g", "lam_x", "lam_g"):
        np.testing.assert_array_equal(sol[name], direct[name], err_msg=name)
    assert packed_stats["return_status"] == direct_stats["return_status"] == "Solve_Succeeded"
    assert packed_stats["iter_count"] == direct_stats["iter_count"]
    assert packed_stats["iterations"] == direct_stats["iterations"]


def test_the_stats_are_those_of_the_last_packed_call():
    """Solves on one kept solver from the default guess and from the optimum's trajectory
    take different iteration counts; each result reports its own (the packed Function's
    stats follow its nlpsol's last call)."""
    problem = dmoc.problems.knife_edge_parking(12)
    cold = solve(problem)
    primal = solve(problem, guess=cold.trajectory)
    again = solve(problem)
    assert primal.stats["solver_reused"] and again.stats["solver_reused"]
    assert primal.stats["iterations"] < cold.stats["iterations"] == again.stats["iterations"]
    assert again.cost == cold.cost


def _problems():
    parking = dmoc.problems.knife_edge_parking(20)
    disc = dmoc.discretize(dmoc.systems.rolling_disk(mass=1.0, radius=1.0), 0.1, rule="lobatto3")
    steering = dmoc.OptimalControlProblem(disc, 20, q_start=[0.0] * 4, q_goal=[1.0, 1.0, None, 1.5])
    far = dmoc.problems.knife_edge_parking(20).with_boundary(q_start=[1e5, -3e4, 0.0],
                                                              q_goal=[1e5, -3e4 + 1.0, 0.0])
    return {"parking": parking, "rolling disk lobatto3": steering, "far from the origin": far}


@pytest.mark.parametrize("name", list(_problems()))
def test_cost_and_most_violated_row_are_those_of_the_returned_x(name):
    """Cold, then warm from the optimum shifted one step (as `MPC.step` does): IPOPT's f
    and g are the NLP's at the returned x, to round-off of the rows (|g| ~ 1e-15)."""
    problem = _problems()[name]
    T = problem.transcription
    cold = solve(problem)
    warm = solve(problem, guess=shifted(cold, problem))
    assert warm.stats["warm_start"]
    for result in (cold, warm):
        f, g = T.separable.values(result.x / T.x_scale, T.p)
        assert result.cost == pytest.approx(f, rel=1e-15, abs=0.0)
        violation, where = most_violated(T, g / T.g_scale)
        assert result.stats["max_violation"] == pytest.approx(violation, rel=0.0, abs=1e-24)
        if violation > 1e-24:
            assert result.stats["most_violated"] == where


def _momentum_problems():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    free = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0], duration=(0.5, 3.0))
    far = dmoc.problems.knife_edge_parking(12).with_boundary(q_start=[1e5, -3e4, 0.1],
                                                              p_start=[0.3, -0.2, 0.1])
    return {"midpoint": dmoc.problems.knife_edge_parking(12), "free final time lobatto3": free,
            "far, start momentum": far}


@pytest.mark.parametrize("name", list(_momentum_problems()))
def test_substituted_momenta_are_the_explicit_p1_of_each_step(name):
    """`Transcription.momenta` (one mapped Function of x and p) against p1 called step by
    step on the blocks of x: p_0 from x, p_{k+1} = p1(q_k, q_{k+1}, s_k, u_k, h), bitwise
    (the same SX algorithm on the same numbers), at a point that is not an optimum."""
    problem = _momentum_problems()[name]
    T, N, lay = problem.transcription, problem.steps, problem.x_layout
    x = solve(problem).x + 1e-3 * np.sin(np.arange(lay.size))
    p1 = problem.momentum_treatment.p1
    q = T.configurations(x)
    h = problem.final_time.step(lay, x)
    blocks = {name: lay.unpack(x, name) for name in ("lam", "s", "u")}
    expected = [lay.unpack(x, "p")[:, 0]]
    for k in range(N):
        values = {"q0": q[k], "q1": q[k + 1], "h": h, **{b: v[:, k] for b, v in blocks.items()}}
        expected.append(np.array(p1(**{i: values[i] for i in p1.name_in()})["p1"]).ravel())
    np.testing.assert_array_equal(T.momenta(x), np.array(expected))


def _bounded_parking(q_goal=(0.0, 1.0, None), **start):
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    return dmoc.OptimalControlProblem(
        disc, 10, q_goal=q_goal, **start, control_bounds=([-20, None], [20, 30]),
        state_bounds=([-0.5, -0.5, None], [0.5, 1.5, None]),
        path_constraints=lambda q, v, u: ca.vertcat(q[2] - 1.0, -q[2] - 1.0))


_RESTATED = {   # (the first statement's start, the new boundary data of `with_boundary`)
    "new start momentum": ({"q_start": [0, 0, 0], "p_start": [0, 0, 0]},
                           {"q_start": [0.1, 0.05, 0.2], "p_start": [0.3, -0.1, 0.2]}),
    "momentum to velocity": ({"q_start": [0, 0, 0], "p_start": [0.1, 0, 0]}, {"v_start": [0, 0, 0]}),
    "velocity to momentum": ({"q_start": [0, 0, 0]}, {"p_start": [0.1, 0.2, 0.0]}),
    "new goal": ({"q_start": [0, 0, 0]}, {"q_goal": [0.2, 1.2, 0.3], "v_goal": [0, 0, 0]}),
}


@pytest.mark.parametrize("case", list(_RESTATED))
def test_with_boundary_states_what_a_new_problem_states(case):
    """`with_boundary` (checks of the changed ends only, the bounds of u, h and g shared)
    against the problem built anew from the same data: the same boundary data, bounds and
    p bitwise, and so the same IPOPT inputs: the same x, multipliers and iterations."""
    first, change = _RESTATED[case]
    restated = _bounded_parking(**first).with_boundary(**change)
    start = {k: v for k, v in {**first, **change}.items()
             if not (k == "p_start" and "v_start" in change or k == "v_start" and "p_start" in change)}
    anew = _bounded_parking(**start)
    for name in ("q_start", "q_goal", "v_start", "v_goal"):
        np.testing.assert_array_equal(getattr(restated, name), getattr(anew, name), err_msg=name)
    assert (restated.p_start is None) == (anew.p_start is None)
    for name in ("lbx", "ubx", "lbg", "ubg", "p", "q_ref"):
        np.testing.assert_array_equal(getattr(restated, name), getattr(anew, name), err_msg=name)
    assert restated.structure == anew.structure
    a, b = solve(restated), solve(anew)
    for name in ("x", "lam_x", "lam_g"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.stats["iterations"] == b.stats["iterations"] and a.success


FIELDS = ("t", "q", "p", "lam", "u", "h", "variant", "mu", "s", "control_nodes", "stage_nodes")


def _trajectory_problems():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule="lobatto3")
    return {**_momentum_problems(),
            "carried momenta": dmoc.OptimalControlProblem(
                disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0], momenta="variables"),
            "(-) variant with mu": dmoc.OptimalControlProblem(
                disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0], variant="-"),
            "rolling disk lobatto4": dmoc.problems.rolling_disk_steering(8, rule="lobatto4")}


@pytest.mark.parametrize("name", list(_trajectory_problems()))
def test_the_results_trajectory_is_what_the_checking_constructor_makes_of_it(name):
    """`trajectory_from_x` assembles the fields without the checks (`Trajectory.unchecked`):
    each must be what ``Trajectory(...)`` (the oracle, which checks and copies) makes of
    the same values, bit for bit, of the same type, shape and dtype, and an array of its
    own (not a view of x); an x with NaN takes the checking constructor itself."""
    problem = _trajectory_problems()[name]
    x = solve(problem).x + 1e-3 * np.cos(np.arange(problem.x_layout.size))
    for point in (x, np.where(np.arange(x.size) == 3, np.nan, x)):
        fast = trajectory_from_x(problem, point)
        checked = Trajectory(*(getattr(fast, f) for f in FIELDS))
        for f in FIELDS:
            a, b = getattr(fast, f), getattr(checked, f)
            assert type(a) is type(b), f
            if isinstance(a, np.ndarray):
                assert a.dtype == b.dtype and a.shape == b.shape and a.base is None, f
                np.testing.assert_array_equal(a.view(np.int64), b.view(np.int64))
            else:
                assert a == b, f


def test_a_non_finite_iterate_is_refused_as_before():
    problem = dmoc.problems.knife_edge_parking(6)
    x = solve(problem).x.copy()
    x[problem.x_layout.slice("u")] = np.inf
    with pytest.raises(dmoc.InputError, match="must be finite; entry"):
        trajectory_from_x(problem, x)


def test_most_violated_row_by_its_definition():
    """The largest violation max(lbg - g, g - ubg, 0) over the rows, a NaN row (or one
    whose bounds and value are both infinite) counting as violated by inf, the first row
    of the largest, and row 0 by 0 when none is violated: against that definition written
    out row by row, on random g with NaN, infinite and feasible entries."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    T = dmoc.OptimalControlProblem(disc, 6, q_start=[0, 0, 0], q_goal=[0, 0.5, None],
                                   path_constraints=lambda q, v, u: q[0] - 1.0).transcription
    lbg, ubg = T.lbg, T.ubg
    assert np.isneginf(lbg).any() and T.g_layout.size > 20
    rng = np.random.default_rng(7)

    def defined(g):
        values = []
        for lo, up, gi in zip(lbg, ubg, g):
            v = max(lo - gi, gi - up) if not np.isnan(gi) else np.nan
            values.append(np.inf if np.isnan(v) else max(v, 0.0))
        i = max(range(len(values)), key=lambda j: (values[j], -j))
        return values[i], i

    for trial in range(300):
        g = np.where(rng.random(lbg.size) < 0.5, rng.normal(size=lbg.size) * 1e-3, 0.0)
        g[lbg == -np.inf] = -np.abs(g[lbg == -np.inf])          # feasible path rows ...
        if trial % 3 == 0:
            g[rng.integers(lbg.size)] = -np.abs(rng.normal())   # ... then perhaps not
        specials = rng.choice([np.nan, np.inf, -np.inf], size=rng.integers(0, 3) * (trial % 2))
        g[rng.choice(lbg.size, size=specials.size, replace=False)] = specials
        if trial % 5 == 0:
            g = np.where(lbg == -np.inf, -1.0, 0.0)             # nothing violated
        with np.errstate(invalid="ignore"):                     # inf - inf
            value, row = defined(g)
            violation, where = most_violated(T, g.copy())
        assert violation == value
        assert where == most_violated(T, np.eye(g.size)[row])[1]    # that row alone violated
