"""What `with_boundary` and `with_parameters` keep from the problem they copy instead of
building it again: the checks of the given ends against the path constraints imposed at
the knots, built once per NLP and set of free entries (`parameters.refuse_violated_ends`),
the state bounds of x's block q, formed again only when q_ref changes, and the entries the
data fix. The oracle is a new OptimalControlProblem stated with the same data, which
builds everything afresh: both must accept the same ends and refuse the others with the
same message, and give the same bounds bit for bit, whatever came before (a piece kept
from other free entries, another q_ref or other parameter values would go stale)."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.errors import InputError, InputTypeError

OBSTACLE = (0.0, 0.5)      # on the way, and at x = 0, where a free x is evaluated


def _problem(q_goal, radius=0.2):
    """Knife-edge parking past a disc of radius w["r"] at OBSTACLE (a row of q alone, so
    imposed at the knots, the ends included)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    return dmoc.OptimalControlProblem(
        disc, 10, q_start=[0, 0, 0], q_goal=q_goal, parameters={"r": radius},
        path_constraints=lambda q, v, u, w: w["r"] ** 2 - ca.sumsqr(q[:2] - ca.DM(OBSTACLE)))


def _outcome(make):
    """The message of the InputError `make()` raises, or None."""
    try:
        make()
    except InputError as err:
        return str(err)
    return None


# refused at r = 0.2: [0, 0.6, 0] and [0.1, 0.5, None] (inside the disc); a goal with x
# free reads no row, so [None, 0.5, 0] is accepted (a check kept from a given x would
# refuse it)
GOALS = [[0, 1, 0], [0, 0.6, 0], [None, 1, 0], [None, 0.5, 0], [0.1, 0.5, None],
         [None, None, 0], [0, 0.6, 0], [0, 1, 0], [None, 0.5, 0]]


@pytest.mark.parametrize("radius", [0.2, 0.05])
def test_with_boundary_refuses_the_ends_a_new_problem_refuses(radius):
    base = _problem([0, 1, 0]).with_parameters(r=radius)
    refused = 0
    for goal in GOALS:          # inside the disc or not, given entries changing
        expected = _outcome(lambda: _problem(goal, radius))
        assert _outcome(lambda: base.with_boundary(q_goal=goal)) == expected, goal
        refused += expected is not None
    assert refused == (3 if radius == 0.2 else 0)


def test_new_parameter_values_are_checked_at_the_ends_with_the_kept_checks():
    """The checks built for r = 0.05 (the goal clear of the disc) refuse the same goal
    once r = 0.2 puts it inside, through `with_parameters` and then `with_boundary`."""
    small = _problem([0, 0.6, 0], radius=0.05)
    assert _outcome(lambda: small.with_boundary(q_goal=[0, 0.62, 0])) is None
    message = _outcome(lambda: small.with_parameters(r=0.2))
    assert message is not None and "q_goal" in message
    assert message == _outcome(lambda: _problem([0, 0.6, 0], radius=0.2))
    clear = _problem([0, 1, 0], radius=0.05).with_parameters(r=0.2)
    assert _outcome(lambda: clear.with_boundary(q_goal=[0, 0.6, 0])) == message
    assert _outcome(lambda: clear.with_boundary(q_start=[0, 0.45, 0])) == \
        _outcome(lambda: dmoc.OptimalControlProblem(
            clear.disc, 10, q_start=[0, 0.45, 0], q_goal=[0, 1, 0], parameters={"r": 0.2},
            path_constraints=lambda q, v, u, w: w["r"] ** 2 - ca.sumsqr(q[:2] - ca.DM(OBSTACLE))))


def test_a_kept_problem_solves_as_a_new_one():
    """The bounds and the optimum of a problem made by `with_boundary` after other checks
    are those of the new problem, bit for bit."""
    moved = _problem([0, 1, 0], 0.05).with_boundary(q_goal=[None, 1, 0]).with_boundary(q_goal=[0.1, 1, 0])
    fresh = _problem([0.1, 1, 0], 0.05)
    for name in ("lbx", "ubx", "lbg", "ubg", "p"):
        np.testing.assert_array_equal(getattr(moved.transcription, name), getattr(fresh.transcription, name))
    a, b = (dmoc.optimize(p, check=False, throw=False) for p in (moved, fresh))
    for name in ("x", "lam_x", "lam_g"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.cost == b.cost


def test_bounds_after_chains_of_new_boundary_data_are_a_new_problems():
    """Chains of `with_boundary` (q_start kept or moved, so q_ref kept or not; goals with
    free entries, whose given entries set q_ref where the start is free) and
    `with_parameters`: lbx, ubx, p and q_ref the same bits as a new problem's, the state
    bounds a signed zero included (the bounds are in the system's units: the new
    problem's scales, set by its own boundary data, do not enter them)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    bounds = ([-0.0, -2.0, None], [3.0, None, 0.0])

    def new(q_start, q_goal, r=1.0):
        return dmoc.OptimalControlProblem(
            disc, 6, q_start=q_start, q_goal=q_goal, state_bounds=bounds, parameters={"r": r},
            running_cost=lambda q, v, u, w: w["r"] * ca.sumsqr(u))
    data = [([0, 0, 0], [1, 1, 0]), ([-0.0, 0, 0], [1, 1, 0]), ([0, 0, 0], [None, 1, -0.5]),
            ([0.5, 0, -0.0], [1, None, 0]), ([None, 0, -1], [2, 1, None]), ([None, 0, -1], [0.0, 1, None]),
            ([0, 0, 0], [1, 1, 0])]
    problem = new(*data[0])
    for q_start, q_goal in data + data[::-1]:
        problem = problem.with_boundary(q_start=q_start, q_goal=q_goal)
        fresh = new(q_start, q_goal)
        for name in ("lbx", "ubx", "p", "q_ref"):
            a, b = getattr(problem.transcription, name), getattr(fresh.transcription, name)
            np.testing.assert_array_equal(a.view(np.int64), b.view(np.int64),
                                          err_msg=f"{name} {q_start} {q_goal}")
    heavier = problem.with_parameters(r=2.0)
    np.testing.assert_array_equal(heavier.transcription.p, new(*data[-1], r=2.0).transcription.p)


def _refusal(make):
    """(the type, the message) of the InputError or InputTypeError `make()` raises, or None."""
    try:
        make()
    except (InputError, InputTypeError) as err:
        return type(err).__name__, str(err)
    return None


def _draw(rng, q):
    """Boundary data for `test_random_chains_of_boundary_data_are_new_problems`: valid
    vectors (None entries, signed zeros, velocities in Delta_Q = ker A(q) at a heading q[2],
    or not) and bad ones (NaN, infinite, a string, a bool, a scalar, a wrong shape)."""
    kind = rng.integers(14)
    if kind == 0:
        return [0.1, float("nan"), 0.0]
    if kind == 1:
        return [np.inf, 0.0, 0.0]
    if kind == 2:
        return [0.0, "1", 0.0]
    if kind == 3:
        return [0.0, True, 0.0]
    if kind == 4:
        return 0.5
    if kind == 5:
        return [0.0, 1.0]
    if kind == 6:
        return [np.float64(np.nan), None, 0.0]
    if kind in (7, 8):                          # along the blade, and turning on the spot
        theta = 0.0 if q is None or q[2] is None else q[2]
        speed = rng.choice([0.0, -0.0, 0.7])
        return [speed * np.cos(theta), speed * np.sin(theta), float(rng.choice([0.0, 0.3]))]
    value = [float(v) for v in rng.uniform(-1.5, 1.5, 3)]     # some outside the state bounds
    value = [-0.0 if abs(v) < 0.1 else v for v in value]
    return [None if rng.random() < 0.3 else v for v in value]


def test_random_chains_of_boundary_data_are_new_problems():
    """Random chains of `with_boundary` (each end's q, v, or p_start given or kept; good and
    bad data) against a new problem of the chain's data: the same refusal, word for word,
    or the same velocity rows, bounds and p bit for bit (so the ends that no argument
    touches keep their checks and rows rightly, and the bounds written into the kept open
    bounds are the full path's)."""
    rng = np.random.default_rng(25)
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    bounds = ([-1.0, -1.2, None], [1.0, None, 1.2])

    def new(data):
        return dmoc.OptimalControlProblem(disc, 4, state_bounds=bounds, **data)

    data = {"q_start": [0.0, 0.0, 0.0], "q_goal": [0.5, 0.5, 0.0], "v_start": [0.0, 0.0, 0.0],
            "v_goal": [0.0, 0.0, 0.0]}
    problem, refused, rebuilt = new(data), 0, 0
    for _ in range(150):
        names = rng.choice(["q_start", "q_goal", "v_start", "v_goal", "p_start"], rng.integers(1, 3),
                           replace=False)
        given = {}
        for name in names:
            end = "q_goal" if name == "v_goal" else "q_start"
            given[name] = _draw(rng, data[end] if name.startswith("v") else None)
        if "v_start" in given and "p_start" in given:
            del given["p_start"]
        changed = {k: v for k, v in data.items() if not (k in ("v_start", "p_start") and
                                                           given.keys() & {"v_start", "p_start"})}
        changed.update(given)
        expected = _refusal(lambda: new(changed))
        got = _refusal(lambda: problem.with_boundary(**given))
        assert got == expected, (given, data)
        if expected is not None:
            refused += 1
            continue
        moved, fresh = problem.with_boundary(**given), new(changed)
        assert moved.velocity_rows == fresh.velocity_rows, (given, data)
        rebuilt += moved.structure != problem.structure
        for name in ("lbx", "ubx", "lbg", "ubg", "p", "q_ref"):
            a, b = getattr(moved.transcription, name), getattr(fresh.transcription, name)
            np.testing.assert_array_equal(a.view(np.int64), b.view(np.int64), err_msg=f"{name} {given}")
        lbg, ubg = moved.transcription.scaled_g_bounds
        np.testing.assert_array_equal(lbg, moved.lbg * moved.g_scale)
        np.testing.assert_array_equal(ubg, moved.ubg * moved.g_scale)
        for name in ("q_start", "q_goal", "v_start", "v_goal"):
            np.testing.assert_array_equal(getattr(moved, name), getattr(fresh, name))
            assert not getattr(moved, name).flags.writeable
        problem, data = moved, changed
    assert 30 < refused < 120 and rebuilt > 3, (refused, rebuilt)


@pytest.mark.parametrize("nan", [float("nan"), np.float64("nan"), np.float32("nan")])
def test_nan_boundary_entries_are_refused_whatever_their_float_type(nan):
    problem = _problem([0, 1, 0])
    with pytest.raises(InputError, match=r"`q_goal` entry 1 is NaN; only None leaves an entry free"):
        problem.with_boundary(q_goal=[0.0, nan, 0.0])
