"""The verdict on an optimum on SO(3) (issue 43, `dmoc.drivers.group_verdict`): each check
made to fail by an optimum judged against another problem or with changed controls, its
figure against one computed here (the angle between two rotations about one axis, the path
row written in numpy, the velocities of `RotationTrajectory.sample` beside each knot), and
the status and message naming it."""

import dataclasses

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc
from dmoc.drivers import group_replay
from dmoc.drivers.group_verdict import judge_on_group
from dmoc.optimal_control.nlp.group_transcription import group_transcription
from dmoc.optimal_control.solver import group_solving
from dmoc.drivers.verdict import judge, judged, knot_path_values

I, THETA, T, N = 2.0, 1.2, 2.0, 6
AXIS = np.array([1.0, 2.0, 2.0]) / 3
QUIET = {"print_level": 0, "sb": "yes"}


def slew(theta, **keywords):
    disc = dmoc.discretize(dmoc.systems.spacecraft((I, I, I)), T / N)
    return dmoc.GroupOptimalControlProblem(disc, N, R_start=np.eye(3),
                                           R_goal=Rotation.from_rotvec(theta * AXIS).as_matrix(),
                                           **keywords)


@pytest.fixture(scope="module")
def optimum():
    problem = slew(THETA)
    return problem, dmoc.optimize(problem, options=QUIET)


def test_a_passed_verdict_is_the_judge_of_both_kinds(optimum):
    problem, result = optimum
    assert result.verdict == judge(problem, result) == judge_on_group(problem, result)
    verdict = result.verdict
    assert verdict.passed and max(verdict.replay_q, verdict.replay_p) <= 1e-12
    assert verdict.goal_error <= 1e-12 and verdict.path_violation == 0.0
    assert result.stats["replay_deviation"] == max(verdict.replay_q, verdict.replay_p)


def test_a_missed_goal_is_named_by_its_angle(optimum):
    """The optimum to 1.2 rad judged against the goal 1.25 rad about the same axis: 0.05 rad."""
    _, result = optimum
    verdict = judge_on_group(slew(THETA + 0.05), result)
    assert verdict.status == "goal_missed" and abs(verdict.goal_error - 0.05) <= 1e-12
    failed = judged(result, verdict, throw=False)
    assert (failed.success, failed.status) == (False, "goal_missed")
    assert "fails its verdict (goal_missed): its last knot misses the goal by 5.00e-02" in failed.message


def test_a_failed_verdict_after_an_acceptable_stop_says_so(optimum):
    """IPOPT's acceptable level is no optimum to `tol`: the message says so beside what the
    verdict found, and does not when IPOPT met `tol`."""
    _, result = optimum
    verdict = judge_on_group(slew(THETA + 0.05), result)
    stopped = dataclasses.replace(result, stats={**result.stats, "return_status": "Solved_To_Acceptable_Level"})
    assert "stopped at its acceptable level" in judged(stopped, verdict, throw=False).message
    assert "acceptable level, not" not in judged(result, verdict, throw=False).message


def test_a_path_row_at_the_knots_is_checked_and_named(optimum):
    """The row u_0 <= 0.4 max u_0: violated where u_0 peaks, by 0.6 max u_0 relative to the
    row's scale max(1, max_k |g_k|)."""
    _, result = optimum
    u0 = result.trajectory.u[:, 0]
    limit = 0.4 * u0.max()
    problem = slew(THETA, path_constraints=lambda R, x, u: u[0] - limit)
    g = np.append(u0, u0[-1]) - limit                    # u_{N-1} at q_N
    assert np.allclose(knot_path_values(problem, result.trajectory)[:, 0], g, rtol=0, atol=1e-15)
    verdict = judge(problem, result)
    assert verdict.status == "path_violated" and verdict.path_step == int(np.argmax(g))
    assert verdict.path_row == 0 and abs(verdict.path_violation - g.max() / max(1.0, np.abs(g).max())) <= 1e-15
    assert verdict.path_limit.startswith("path_constraints row 0 (") and "u_0" in verdict.path_limit


def test_a_rotation_keep_out_row_reads_R(optimum):
    """A row on R alone: the body axis R e1 kept off a direction c, cos(angle) <= 0.99;
    its values at the knots as written here."""
    _, result = optimum
    c = np.array([0.0, 0.6, 0.8])
    problem = slew(THETA, path_constraints=lambda R, x, u: ca.dot(ca.mtimes(R, ca.DM([1, 0, 0])), c) - 0.99)
    assert np.allclose(knot_path_values(problem, result.trajectory)[:, 0],
                       result.trajectory.R[:, :, 0] @ c - 0.99, rtol=0, atol=1e-15)


def test_the_velocity_jumps_are_those_of_the_sampled_motion(optimum):
    """|Omega(t_k+) - Omega(t_k-)| / peak from `sample` just beside each interior knot."""
    _, result = optimum
    traj = result.trajectory
    eps = 1e-9
    after, before = (traj.sample(traj.t[1:-1] + s).v for s in (eps, -eps))
    ends = np.vstack([traj.sample(traj.t[:-1] + eps).v, traj.sample(traj.t[1:] - eps).v])
    changes = np.abs(after - before) / np.abs(ends).max(axis=0)
    assert abs(result.verdict.velocity_jump - changes.max()) <= 1e-6
    assert result.verdict.jump_step == 1 + np.unravel_index(np.argmax(changes), changes.shape)[0]


def test_controls_that_do_not_replay_are_named(optimum):
    problem, result = optimum
    traj = dataclasses.replace(result.trajectory, u=1.01 * result.trajectory.u)
    verdict = judge_on_group(problem, dataclasses.replace(result, trajectory=traj))
    assert verdict.status == "not_replayable" and verdict.replay_step == 1
    message = judged(result, verdict, throw=False).message
    assert "Use more steps, so that no step turns the body by a large angle" in message


def test_the_verdict_and_its_estimate_survive_a_file(optimum, tmp_path):
    problem = slew(THETA)
    result = dmoc.optimize(problem, estimate=True, options=QUIET)
    result.save(tmp_path / "slew.npz")
    back = dmoc.OptimizationResult.load(tmp_path / "slew.npz")
    assert back.verdict == result.verdict and back.verdict.discretization_error > 0
    assert back.stats["error_estimate"] == result.stats["error_estimate"]


def test_the_verdict_refuses_a_result_of_other_steps(optimum):
    problem, result = optimum
    with pytest.raises(dmoc.InputError, match="`result` must be an optimum of `problem` \\(12 steps\\)"):
        judge_on_group(problem.with_steps(12), result)


@pytest.mark.parametrize("factor", [1.01, 300.0])
def test_the_replay_on_the_nlp_rows_is_the_simulators_or_hands_over_to_it(optimum, factor):
    """Changed controls replayed by Newton on the NLP's step rows: the simulator's steps to
    the simulator's tolerance; torques so large that 4 Newton updates do not converge: no replay there
    (None), and the verdict takes the simulator's replay: not replayable."""
    from dmoc.drivers.group_replay import nlp_replay
    problem, result = optimum
    traj = dataclasses.replace(result.trajectory, u=factor * result.trajectory.u)
    simulated = dmoc.simulate(problem.disc, q0=traj.R[0], p0=traj.p[0], steps=N, controls=traj.u,
                              throw=False, jit=False).trajectory
    replay = nlp_replay(problem, traj)
    if factor < 2:
        assert replay.steps == N
        # each step of both converged to the simulator's tol 1e-12 (which also re-orthogonalizes R)
        assert np.abs(replay.q - simulated.q).max() <= 1e-11
        assert np.abs(replay.p - simulated.p).max() <= 1e-11
    else:
        assert replay is None
        verdict = judge_on_group(problem, dataclasses.replace(result, trajectory=traj))
        assert verdict.status == "not_replayable"


def test_a_judged_solve_builds_its_transcription_once(monkeypatch):
    """The verdict's replay takes the transcription the solve built (`judged_solve_on_group`
    passes it on): one `group_transcription` per judged solve, and the verdict the one a
    replay with its own transcription gives."""
    from dmoc.drivers import group_optimum
    built = []

    def counted(problem):
        built.append(problem)
        return group_transcription(problem)
    monkeypatch.setattr(group_optimum, "group_transcription", counted)
    monkeypatch.setattr(group_replay, "group_transcription", counted)
    monkeypatch.setattr(group_solving, "group_transcription", counted)
    problem = slew(THETA)
    result = dmoc.optimize(problem)
    assert result.verdict.passed and len(built) == 1
    assert judge_on_group(problem, result) == result.verdict and len(built) == 2


def test_the_replay_builds_the_newton_update_and_the_step_only(monkeypatch, optimum):
    """The replay's horizon makes two MX Functions, the Newton update and the step that
    calls it NEWTON_ITERATIONS times and ends with the term's rows itself (no Function of
    its own for the end), and replays the optimum onto itself."""
    problem, result = optimum
    made, real = [], ca.Function

    def counted(*args, **keywords):
        made.append(args[0])
        return real(*args, **keywords)
    monkeypatch.setattr(group_replay.ca, "Function", counted)
    group_replay._HORIZONS.clear()
    replay = group_replay.nlp_replay(problem, result.trajectory)
    assert made == ["replay_update", "replay_step"]
    assert np.abs(replay.q - result.trajectory.q).max() <= 1e-10


@pytest.mark.parametrize("omega_start, masses", [(None, 0), ([0.3, -0.2, 0.1], 1)])
def test_the_replay_from_rest_starts_at_zero_without_the_mass_matrix(monkeypatch, omega_start, masses):
    """The replay's first warm start f_0 = h M(q_0)^{-1} p_0: 0 from rest without evaluating
    M; from a moving start M once. Either way the optimum replays onto itself."""
    problem = slew(THETA, **({} if omega_start is None else {"omega_start": omega_start}))
    result = dmoc.optimize(problem, options=QUIET)
    system, calls = problem.disc.system, []
    real = system.generalized_mass
    monkeypatch.setattr(system, "generalized_mass", lambda q: calls.append(q) or real(q))
    replay = group_replay.nlp_replay(problem, result.trajectory)
    assert len(calls) == masses and (np.abs(result.trajectory.p[0]).max() > 0) == bool(masses)
    assert np.abs(replay.q - result.trajectory.q).max() <= 1e-10
    assert np.abs(replay.p - result.trajectory.p).max() <= 1e-10
