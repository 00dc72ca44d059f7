"""The verdict on the path a re-solve takes (issue 41): with the replay's stepper, the end
velocities' and the path's mapped Functions kept from an earlier verdict of the same
structure, a deliberately wrong optimum is refused as from a process with every cache
emptied; and `dmoc.optimize` records what its verdict cost.

Oracle, not taken from dmoc's code: the knife edge's heading theta has no potential, no
constraint force (A(q) = (-sin theta, cos theta, 0)) and inertia J = 1, so the discrete
momentum balance of every rule gives p_theta,k+1 - p_theta,k = h sum_i b_i u1_i (the
quadrature weights b_i sum to 1): a torque raised by delta at every control node of step
k moves the replay's p_theta by exactly h delta off the optimum's from step k + 1 on, and
nothing before.
"""

import dataclasses

import numpy as np
import pytest

import dmoc
from dmoc.drivers.verdict import REPLAY_TOLERANCE, judge, verdicts
from dmoc.problems import knife_edge_parking

DELTA, STEP = 1e-2, 5          # the torque's change, at this step


def with_torque_raised(result, k, delta):
    """`result` with the torque u1 raised by `delta` at every control node of step `k`
    (controls u = (u0, u1) at each node, node after node), q and p kept."""
    traj = result.trajectory
    u = traj.u.copy()
    u[k, 1::2] += delta
    return dataclasses.replace(result, trajectory=dmoc.Trajectory(
        traj.t, traj.q, traj.p, traj.lam, u, traj.h, traj.variant, traj.mu, traj.s,
        traj.control_nodes, traj.stage_nodes))


@pytest.mark.parametrize("rule, steps", [("midpoint", 20), ("lobatto3", 12)])
def test_a_perturbed_control_is_refused_on_the_kept_functions_as_from_empty_caches(rule, steps):
    problem = knife_edge_parking(steps, rule=rule)
    sound = dmoc.optimize(problem, check=False)
    wrong = with_torque_raised(sound, STEP, DELTA)
    assert judge(problem, sound).passed              # the structure judged: its Functions kept
    warm = judge(problem, wrong)
    dmoc.clear_caches()
    cold = judge(problem, wrong)
    assert warm == cold
    assert warm.status == "not_replayable" and not warm.passed
    assert warm.replay_step == STEP + 1
    size = np.abs(sound.trajectory.p).max()
    # p_theta departs by h delta from step k + 1 on, and more than x's and y's momenta
    assert warm.replay_p == pytest.approx(problem.disc.h * DELTA / size, rel=1e-9)
    assert warm.replay_p > REPLAY_TOLERANCE
    grouped = verdicts([(problem, sound), (problem, wrong)])        # the batch's path
    assert grouped[0].passed and grouped[1] == warm


def test_optimize_records_its_verdicts_seconds():
    problem = knife_edge_parking(20)
    judged = dmoc.optimize(problem)
    assert judged.verdict.passed and type(judged.stats["verdict_time"]) is float
    assert judged.stats["verdict_time"] > 0
    assert "verdict_time" not in dmoc.optimize(problem, check=False).stats
    again = dmoc.optimize(problem.with_boundary(q_goal=[0.0, 1.1, 0.0]), guess=judged)
    assert again.verdict.passed and again.stats["verdict_time"] > 0
