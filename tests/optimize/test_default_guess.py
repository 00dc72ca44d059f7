"""The default guess's free goal entries: a coordinate whose goal is free moves on at the
given start velocity over the guess's duration N h (the closed form written here), instead
of standing at its start while the other coordinates move; without a start velocity it is
held. The lane change past a parked car (examples/lane_change_problem.py: a car at 10 m/s
towards a free goal x) solved by the midpoint rule from that guess reaches the optimum it
reaches from the 45-step optimum resampled (an independent start), where the guess that
held x at 0 ended ``Infeasible_Problem_Detected`` from N = 90 on."""

import sys
from pathlib import Path

import numpy as np

import dmoc
from dmoc.optimal_control.solver.guess import initial_guess

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
from lane_change_problem import lane_change  # noqa: E402


def guessed_q(problem):
    T = problem.transcription
    return T.x_layout.unpack(initial_guess(problem), "q").T + T.q_ref     # (N + 1, n)


def test_a_free_goal_entry_moves_on_at_the_start_velocity():
    car, N, h = dmoc.systems.car(wheelbase=2.7), 20, 0.1
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(car, h), N, q_start=[1.0, 0.0, 0.0, 0.0], v_start=[10.0, 0.0, 0.0, 0.0],
        q_goal=[None, 3.5, None, 0.0], v_goal=[None] * 4)
    q = guessed_q(problem)
    assert q[0].tolist() == [1.0, 0.0, 0.0, 0.0]
    assert q[-1, 0] == 1.0 + 10.0 * N * h          # x: driven on at 10 m/s for N h = 2 s
    assert q[-1, 1] == 3.5                          # y: the goal
    assert abs(q[-1, 2]) <= 1e-15                   # theta: free, no start velocity: held (its bump's sin(pi))
    assert np.all(np.diff(q[:, 0]) > 0)


def test_the_lane_change_solves_from_the_default_guess_where_it_was_infeasible():
    from_default = dmoc.optimize(lane_change(90).with_rule("midpoint"))
    coarse = dmoc.optimize(lane_change(45).with_rule("midpoint"))
    from_coarse = dmoc.optimize(lane_change(90).with_rule("midpoint"), guess=coarse.trajectory)
    assert from_default.success and from_default.verdict.status == "passed"
    assert abs(from_default.cost - from_coarse.cost) <= 1e-9 * from_coarse.cost
    assert abs(from_default.trajectory.t[-1] - from_coarse.trajectory.t[-1]) <= 1e-7
