"""The verdicts of many optima at once (`dmoc.drivers.verdict.verdicts`, what a batch's chunk
judges its optima with): each Verdict bit for bit the one of judging the optimum alone,
whatever else is in the group.

Oracles, none taken from the grouped code:
- the replay figures written out here from a `dmoc.simulate` run of each optimum alone
  (the replay as `judge` made it before the verdicts were grouped);
- the velocity jumps of the midpoint rule from `Trajectory.velocities` (the step
  velocities, not the interpolant's end velocities the verdict evaluates);
- judging each optimum alone (`judge`, the group of one) in a process state where the
  group's other members were never judged;
- the statuses of the problems of tests/results/test_verdict.py, each of which is made
  here for real (passed, under_resolved, path_violated, not_replayable).
"""

import dataclasses

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.diagnostics import velocity_jumps
from dmoc.problems import knife_edge_parking, rolling_disk_steering
from dmoc.drivers.verdict import REPLAY_TOLERANCE, judge, verdicts


def rate_limited(limit, steps=50):
    """Knife-edge parking under a heading-rate limit (lobatto3), judged with the optimum of
    the parking without it (`optima`), whose knots cross it (test_verdict.py:
    path_violated; the NLP holds the limit at every knot, so its own optimum passes)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / steps, "lobatto3")
    return dmoc.OptimalControlProblem(disc, steps, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                      path_constraints=lambda q, v, u: ca.vertcat(v[2] - limit, -v[2] - limit))


def obstacle(centre):
    """The differential drive past a disc obstacle whose centre is a parameter w["c"]
    (tests/optimize/test_knot_path.py): optima of one path Function, other parameters."""
    disc = dmoc.discretize(dmoc.systems.differential_drive(), 4.0 / 12)
    problem = dmoc.OptimalControlProblem(
        disc, 12, q_start=[0, 0, 0, 0, 0], q_goal=[2.0, 0, 0, None, None],
        path_constraints=lambda q, v, u, w: 0.09 - ca.sumsqr(q[:2] - w["c"]),
        parameters={"c": [1.0, 0.05]})
    return problem.with_parameters(c=centre)


def car():
    disc = dmoc.discretize(dmoc.systems.car(mass=1500.0), 3.0 / 60)
    return dmoc.OptimalControlProblem(disc, 60, q_start=[0.0] * 4, q_goal=[40.0, 3.5, 0.0, 0.0])


@pytest.fixture(scope="module")
def optima():
    """(problem, IPOPT's optimum) of random goals of several structures, rules, variants and
    steps, shuffled: every status of the verdict among them."""
    rng = np.random.default_rng(26)
    parking = knife_edge_parking(20)
    problems = [parking.with_boundary(q_goal=[0.0, y, 0.1]) for y in rng.uniform(0.2, 2.0, 4)]
    problems += [knife_edge_parking(20, variant="-").with_boundary(q_goal=[0.0, y, 0.1])
                 for y in rng.uniform(0.2, 2.0, 2)]
    problems += [knife_edge_parking(10).with_boundary(q_goal=[0.0, y, 0.1]) for y in (0.2, 2.0)]
    problems += [knife_edge_parking(12, rule="lobatto3").with_boundary(q_goal=[0.0, 1.3, 0.2]),
                 rolling_disk_steering(11, rule="lobatto4"), rate_limited(0.3), rate_limited(0.4),
                 car(), obstacle([1.0, 0.05]), obstacle([1.1, -0.1])]
    problems = [problems[i] for i in rng.permutation(len(problems))]
    free = dmoc.optimize(knife_edge_parking(50, rule="lobatto3"), check=False)     # for rate_limited
    return [(p, free if p.path_constraints is not None and p.steps == 50 else
             dmoc.optimize(p, check=False, throw=False)) for p in problems]


def replay_oracle(problem, traj):
    """(replay_q, replay_p, replay_step) written out from a `dmoc.simulate` run alone."""
    run = dmoc.simulate(problem.disc.with_step(traj.h), q0=traj.q[0], p0=traj.p[0],
                        steps=traj.steps, controls=traj.u, variant=traj.variant, throw=False,
                        jit=False).trajectory
    if run.steps < traj.steps:
        return np.inf, np.inf, run.steps + 1
    last = traj.steps + (traj.variant == "+")           # p_N of "-" holds the end impulse
    span = next((s for s in (np.ptp(traj.q, axis=0).max(), np.abs(traj.q).max()) if s > 1e-12), 1.0)
    size = next((s for s in (np.abs(traj.p).max(),) if s > 1e-12), 1.0)
    dq = np.abs(run.q - traj.q).max(axis=1) / span
    dp = np.abs(run.p[:last] - traj.p[:last]).max(axis=1) / size
    beyond = np.flatnonzero((dq[:last] > REPLAY_TOLERANCE) | (dp > REPLAY_TOLERANCE))
    return dq.max(), dp.max(), beyond[0] if beyond.size else -1


def assert_same(a, b):
    """Two Verdicts equal field by field, floats bit for bit."""
    for name, value in a.as_dict().items():
        other = getattr(b, name)
        assert type(other) is type(value) and repr(other) == repr(value), name


def test_the_verdicts_of_a_group_equal_each_optimum_judged_alone(optima):
    assert all(r.stats["return_status"] == "Solve_Succeeded" for _, r in optima)
    grouped = verdicts(optima)
    alone = []
    for problem, result in optima:
        dmoc.clear_caches()                     # no Function kept from the group
        alone.append(judge(problem, result))
    for a, b in zip(grouped, alone):
        assert_same(a, b)
    assert {v.status for v in grouped} == {"passed", "under_resolved", "path_violated",
                                           "not_replayable"}


def test_any_part_of_a_group_gets_the_verdicts_of_the_whole(optima):
    whole = verdicts(optima)
    order = np.random.default_rng(1).permutation(len(optima))[:7]
    for got, i in zip(verdicts([optima[i] for i in order]), order):
        assert_same(got, whole[i])
    assert verdicts([]) == []


def test_the_replay_figures_equal_the_replays_alone(optima):
    for (problem, result), verdict in zip(optima, verdicts(optima)):
        q, p, step = replay_oracle(problem, result.trajectory)
        assert (verdict.replay_q, verdict.replay_p, verdict.replay_step) == (q, p, step)


def test_the_midpoint_velocity_jumps_are_those_of_the_step_velocities(optima):
    midpoint = [(p, r) for p, r in optima if p.disc.rule.name == "midpoint"
                and p.disc.system.n == 3]
    for (problem, result), verdict in zip(midpoint, verdicts(midpoint)):
        np.testing.assert_allclose(verdict.velocity_jump,
                                   velocity_jumps(result.trajectory).max(), rtol=1e-12)


def test_an_optimum_simulate_refuses_to_replay_raises_for_the_group(optima):
    """A group raises the error of its first optimum that `simulate` refuses (here a start
    q_0 of NaN), as judging that one alone raises it; the batch then judges each alone."""
    problem, result = optima[0]
    traj = result.trajectory
    broken = dataclasses.replace(result, trajectory=dmoc.Trajectory(
        traj.t, np.vstack([np.full((1, traj.q.shape[1]), np.nan), traj.q[1:]]), traj.p,
        traj.lam, traj.u, traj.h, traj.variant, traj.mu, traj.s, traj.control_nodes,
        traj.stage_nodes))
    with pytest.raises(dmoc.InputError, match="q0") as alone:
        judge(problem, broken)
    with pytest.raises(dmoc.InputError, match="q0") as grouped:
        verdicts([optima[1], (problem, broken), optima[2]])
    assert str(grouped.value) == str(alone.value)


def test_the_path_figures_of_a_group_read_each_optimums_own_parameters(optima):
    """The obstacle's g_k = 0.09 - |(x_k, y_k) - c|^2 at every knot (the midpoint rule's
    path Function reads its straight step's midpoint, the knot itself), each optimum with
    its own centre c: the group's path figures against that formula written out in NumPy
    (largest g_k over max(1, max_k |g_k|), its knot; none when no g_k > 0)."""
    pairs = [(p, r) for p, r in optima if "c" in p.parameter_values]
    assert len({tuple(p.parameter_values["c"]) for p, _ in pairs}) == 2
    for (problem, result), verdict in zip(pairs, verdicts(pairs)):
        q = result.trajectory.q
        g = 0.09 - np.sum((q[:, :2] - problem.parameter_values["c"]) ** 2, axis=1)
        relative = g / max(1.0, np.abs(g).max())
        k = int(np.argmax(relative))
        expected = (float(relative[k]), k, 0) if relative[k] > 0 else (0.0, -1, -1)
        assert verdict.path_violation == pytest.approx(expected[0], rel=1e-9, abs=1e-12)
        assert (verdict.path_step, verdict.path_row) == expected[1:]
