"""dmoc.MPC, the receding-horizon controller.

Oracles, none from the controller itself: the cold solve of the same problem statement
from the default guess (each warm-started step must reach its optimum), the same start
given by its velocity (the first plan must be the optimum of `optimize` from (q, v)), and
the simulator (`dmoc.simulate` of the applied controls, from the measured state, must land
on the plan's q_1, p_1: both solve the same step residual). What the controller hands
IPOPT and records is checked against values written here: the columns of the warm
start (the last optimum's, moved by the steps since it), IPOPT's own max_iter for a
stopped solve's iterations, the momentum M v of a measured velocity, the wall clock
around a step.
"""

import dataclasses
import time

import numpy as np
import pytest

import dmoc
from dmoc._util.deferred import Pending
from dmoc.drivers import mpc
from dmoc.drivers.mpc import shifted
from dmoc.optimal_control import solve


def parking(rule="midpoint", steps=12):
    return dmoc.problems.knife_edge_parking(steps, duration=0.1 * steps, rule=rule)


@pytest.mark.parametrize("rule", ["midpoint", "lobatto3"])
def test_closed_loop_steps_are_the_optima_and_the_plant_follows_the_plan(rule):
    problem = parking(rule)
    controller = dmoc.MPC(problem)
    q, v = np.zeros(3), np.array([0.2, 0.0, 0.1])
    first = dmoc.optimize(problem.with_boundary(v_start=v))
    u = controller.step(q, v=v)
    np.testing.assert_allclose(controller.plan.cost, first.cost, rtol=1e-9)
    np.testing.assert_allclose(u, first.trajectory.u[0], rtol=0, atol=1e-8)
    p = np.array(problem.disc.system.momentum(q, v)).ravel()
    for k in range(4):
        plan = controller.plan.trajectory
        run = dmoc.simulate(problem.disc, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        np.testing.assert_allclose(q, plan.q[1], rtol=0, atol=1e-9)
        np.testing.assert_allclose(p, plan.p[1], rtol=0, atol=1e-8)
        u = controller.step(q, p=p)
        cold = dmoc.optimize(problem.with_boundary(q_start=q, p_start=p))
        np.testing.assert_allclose(controller.plan.cost, cold.cost, rtol=1e-8)
        np.testing.assert_allclose(u, cold.trajectory.u[0], rtol=0, atol=1e-6)
    log = controller.log
    assert len(log) == 5 and all(r.success for r in log)
    assert [r.warm_start for r in log] == [False] + [True] * 4
    assert max(r.iterations for r in log[1:]) < log[0].iterations
    assert all(r.step_time >= r.solve_time > 0 for r in log)
    np.testing.assert_array_equal(log[-1].q, q)



def test_a_step_applies_the_plans_first_controls_and_leaves_its_trajectory_unmade():
    """The applied controls are read from the plan's x: bit for bit its trajectory's first
    controls, and the trajectory (made on first access) is not made by the step."""
    controller = dmoc.MPC(parking("lobatto3"))
    controller.step(np.zeros(3), p=np.zeros(3))
    first = controller.plan
    u = controller.step(np.array([0.01, 0.0, 0.02]), p=np.zeros(3))   # warm: `first` shifted
    for plan in (first, controller.plan):
        assert isinstance(vars(plan)["trajectory"], Pending)
    np.testing.assert_array_equal(u, controller.plan.trajectory.u[0])
    assert u.shape == (len(controller.problem.disc.rule.control_nodes) * 2,)


def test_the_warm_start_is_the_plan_moved_one_step():
    problem = parking("lobatto3").with_boundary(p_start=[0.0, 0.0, 0.0])
    result = dmoc.optimize(problem)
    moved = shifted(result, problem)
    lay, g_lay, N = problem.x_layout, problem.g_layout, problem.steps
    for name in ("q", "lam", "s", "u"):
        old, new = lay.unpack(result.x, name), lay.unpack(moved.x, name)
        np.testing.assert_array_equal(new[:, :-1], old[:, 1:])
        np.testing.assert_array_equal(new[:, -1], old[:, -1])
        np.testing.assert_array_equal(lay.unpack(moved.lam_x, name)[:, :-1], lay.unpack(result.lam_x, name)[:, 1:])
    old, new = g_lay.unpack(result.lam_g, "dynamics"), g_lay.unpack(moved.lam_g, "dynamics")
    np.testing.assert_array_equal(new[:, :-1], old[:, 1:])
    for name in ("p", "v_goal", "nu"):          # p_0 alone (substituted momenta), boundary blocks
        np.testing.assert_array_equal(lay.unpack(moved.x, name), lay.unpack(result.x, name))
    np.testing.assert_array_equal(g_lay.unpack(moved.lam_g, "goal"), g_lay.unpack(result.lam_g, "goal"))
    assert moved.structure == result.structure and N == 12
    by_three = shifted(result, problem, 3)          # after two failed solves (on_failure="shift")
    for name in ("q", "u"):
        old, new = lay.unpack(result.x, name), lay.unpack(by_three.x, name)
        np.testing.assert_array_equal(new[:, :-3], old[:, 3:])
        np.testing.assert_array_equal(new[:, -3:], np.repeat(old[:, -1:], 3, axis=1))


def test_bad_measurements_and_problems_are_refused():
    controller = dmoc.MPC(parking())
    with pytest.raises(dmoc.InputError, match="give the measured state as `v` or as `p`, exactly one"):
        controller.step([0, 0, 0])
    with pytest.raises(dmoc.InputError, match="give the measured state as `v` or as `p`, exactly one"):
        controller.step([0, 0, 0], v=[0, 0, 0], p=[0, 0, 0])
    with pytest.raises(dmoc.InputError, match=r"`q` must have shape \(3,\)"):
        controller.step([0, 0], p=[0, 0, 0])
    free = dmoc.OptimalControlProblem(parking().disc, 10, q_start=[0, 0, None], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.InputError, match="`problem` must have a fully given `q_start`"):
        dmoc.MPC(free)
    assert controller.log == []


def test_the_closed_loop_example_runs_with_a_short_horizon(tmp_path, capsys):
    """examples/mpc_knife_edge.py (a heavier plant, a kick at step 10): every step solved,
    the kick felt by the plant, both figures written."""
    from tests.docs.test_examples import _load

    closed_loop, log = _load("mpc_knife_edge").main(steps=14, out=tmp_path, horizon=8)
    assert len(log) == 14 and all(r.status == "Solve_Succeeded" for r in log)
    assert closed_loop.steps == 14 and np.isfinite(closed_loop.q).all()
    assert "final state" in capsys.readouterr().out
    for name in ("path", "solve_times"):
        assert (tmp_path / f"mpc_knife_edge_{name}.png").stat().st_size > 1000


def _failing(steps, **keywords):
    """(the model problem, its optimum from rest, a controller that starts there): its first
    solve starts at that optimum (0 iterations); IPOPT may take 2 iterations, and every
    later step (3-4 from the shifted plan) fails."""
    problem = parking(steps=steps)
    optimum = solve(problem.with_boundary(p_start=[0.0, 0.0, 0.0]))
    controller = dmoc.MPC(problem, guess=optimum, options={"max_iter": 2}, **keywords)
    return problem, optimum, controller


def test_a_failed_solve_raises_by_default_and_is_recorded():
    problem, optimum, controller = _failing(12)
    u = controller.step(np.zeros(3), p=np.zeros(3))
    plan = optimum.trajectory
    with pytest.raises(dmoc.SolverError, match=r"MPC step 1: IPOPT: Maximum_Iterations_Exceeded.*"
                                               r"No control is applied \(on_failure='raise'\)") as err:
        controller.step(plan.q[1], p=plan.p[1])
    assert not err.value.result.success
    assert [r.success for r in controller.log] == [True, False] and controller.log[1].u is None
    assert controller.plan.cost == optimum.cost
    np.testing.assert_array_equal(u, plan.u[0])


def test_on_failure_shift_follows_the_last_plan_until_it_is_used_up():
    """After each failed solve the controls of the last optimum's next step; a plant that is
    the model then stays on that optimum's states (the simulator, from the measured
    state), until N failed solves in a row leave no plan."""
    problem, optimum, controller = _failing(4, on_failure="shift")
    plan = optimum.trajectory
    q, p = np.zeros(3), np.zeros(3)
    for k in range(4):
        u = controller.step(q, p=p)
        np.testing.assert_array_equal(u, plan.u[k])
        run = dmoc.simulate(problem.disc, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        np.testing.assert_allclose(q, plan.q[k + 1], rtol=0, atol=1e-9)
        np.testing.assert_allclose(p, plan.p[k + 1], rtol=0, atol=1e-8)
    assert [(r.success, r.plan_age) for r in controller.log] == [
        (True, 0), (False, 1), (False, 2), (False, 3)]
    assert controller.plan is not None and controller.plan.cost == optimum.cost
    with pytest.raises(dmoc.SolverError, match=r"MPC step 4: .*plan is used up \(4 failed solves in a row\)"):
        controller.step(q, p=p)
    last = controller.log[-1]
    assert len(controller.log) == 5 and last.u is None and last.plan_age is None


def test_on_failure_shift_raises_when_the_first_solve_fails():
    controller = dmoc.MPC(parking(), options={"max_iter": 2}, on_failure="shift")
    with pytest.raises(dmoc.SolverError, match="no plan to follow: the first solve failed"):
        controller.step(np.zeros(3), p=np.zeros(3))
    with pytest.raises(dmoc.InputError, match=r"`on_failure` must be one of 'raise', 'shift'; got 'apply'"):
        dmoc.MPC(parking(), on_failure="apply")


def _solves_recorded(monkeypatch, stopped=()):
    """The guesses the controller hands to IPOPT, one per step, in a list that fills as it
    steps; the solves numbered in `stopped` (from 0) run with max_iter = 1."""
    guesses = []

    def recorded(problem, **keywords):
        if len(guesses) in stopped:
            keywords = {**keywords, "options": {"max_iter": 1}}
        guesses.append(keywords["guess"])
        return solve(problem, **keywords)
    monkeypatch.setattr(mpc, "solve", recorded)
    return guesses


def test_each_warm_start_is_the_last_optimum_moved_by_the_steps_since_it(monkeypatch):
    """The guesses handed to IPOPT, read block by block: step 1's is the step-0 optimum with
    column k of q, u and the dynamics multipliers taken from column k + 1 (the last
    repeated); after step 1's solve stopped (on_failure="shift"), step 2's from k + 2. The
    columns are written out here, not taken from `shifted`."""
    guesses = _solves_recorded(monkeypatch, stopped={1})
    controller = dmoc.MPC(parking(steps=6), on_failure="shift")
    controller.step(np.zeros(3), p=[0.1, 0.0, 0.1])
    optimum, plan = controller.plan, controller.plan.trajectory
    controller.step(plan.q[1], p=plan.p[1])
    controller.step(plan.q[2], p=plan.p[2])
    assert guesses[0] is None and [r.success for r in controller.log] == [True, False, True]
    lay, g_lay = controller.problem.x_layout, controller.problem.g_layout
    for by, guess in ((1, guesses[1]), (2, guesses[2])):
        for layout, vector, name in ((lay, "x", "q"), (lay, "x", "u"), (g_lay, "lam_g", "dynamics")):
            old, new = (layout.unpack(getattr(v, vector), name) for v in (optimum, guess))
            columns = [min(k + by, old.shape[1] - 1) for k in range(old.shape[1])]
            np.testing.assert_array_equal(new, old[:, columns])


def test_after_a_stopped_solve_the_next_optimum_is_applied_and_each_solve_recorded(monkeypatch):
    """on_failure="shift": step 1's solve stops at max_iter = 1 (the plan's step 1 is
    applied), step 2's converges and its own first controls are applied, those of the cold
    optimum from the same state; the log holds each solve's own success, IPOPT status and
    iteration count (1, IPOPT's max_iter, for the stopped one). The cold optimum is
    IPOPT's alone (`solve`, as the controller's): 0.6 s from a moving start is too short a
    horizon for `optimize`'s verdict."""
    _solves_recorded(monkeypatch, stopped={1})
    problem = parking(steps=6)
    controller = dmoc.MPC(problem, on_failure="shift")
    controller.step(np.zeros(3), p=[0.1, 0.0, 0.1])
    plan = controller.plan.trajectory
    np.testing.assert_array_equal(controller.step(plan.q[1], p=plan.p[1]), plan.u[1])
    u = controller.step(plan.q[2], p=plan.p[2])
    cold = solve(problem.with_boundary(q_start=plan.q[2], p_start=plan.p[2]))     # no verdict
    np.testing.assert_allclose(u, cold.trajectory.u[0], rtol=0, atol=1e-6)
    log = controller.log
    assert [(r.success, r.status, r.plan_age) for r in log] == [
        (True, "Solve_Succeeded", 0), (False, "Maximum_Iterations_Exceeded", 1),
        (True, "Solve_Succeeded", 0)]
    assert log[1].iterations == 1 < log[0].iterations


def test_a_ctrl_c_is_raised_under_on_failure_shift_not_followed_by_the_old_plan(monkeypatch):
    """on_failure="shift" follows the last plan after a failed solve, never after a Ctrl-C:
    step 1's solve reports what `solve` reports for a SIGINT inside IPOPT (status
    "interrupted", tests/test_interrupts.py), and the step raises dmoc.Interrupted with
    that result, records no control and keeps the plan of step 0."""
    def interrupted(problem, **keywords):
        result = solve(problem, **{**keywords, "options": {"max_iter": 1}})
        return dataclasses.replace(result, success=False, status="interrupted",
                                   message="IPOPT: interrupted (KeyboardInterrupt) after 1 iterations.")
    controller = dmoc.MPC(parking(steps=6), on_failure="shift")
    controller.step(np.zeros(3), p=[0.1, 0.0, 0.1])
    plan = controller.plan
    monkeypatch.setattr(mpc, "solve", interrupted)
    with pytest.raises(dmoc.Interrupted, match="MPC step 1: IPOPT: interrupted") as info:
        controller.step(plan.trajectory.q[1], p=plan.trajectory.p[1])
    assert info.value.result.status == "interrupted"
    assert [(r.status, r.u is None, r.plan_age) for r in controller.log] == [
        ("Solve_Succeeded", False, 0), ("interrupted", True, None)]
    assert controller.plan is plan


def test_a_measured_velocity_enters_as_its_momentum():
    """A knife edge with m = 2, J = 0.5, so dL/dv = diag(m, m, J) v (written here) is not v:
    a step from (q, v) records and imposes p_start = M v, and applies the first controls
    of the optimum of the same problem started from the velocity v."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=2.0, inertia=0.5), 0.1)
    problem = dmoc.OptimalControlProblem(disc, 6, q_start=[0, 0, 0], q_goal=[0, 0.3, 0])
    q, v = np.array([0.0, 0.0, 0.1]), np.array([0.2 * np.cos(0.1), 0.2 * np.sin(0.1), 0.3])
    controller = dmoc.MPC(problem)
    u = controller.step(q, v=v)
    p = np.array([2.0, 2.0, 0.5]) * v
    np.testing.assert_allclose(controller.log[0].p, p, rtol=1e-15, atol=0)
    np.testing.assert_allclose(controller.problem.p_start, p, rtol=1e-15, atol=0)
    from_v = dmoc.optimize(problem.with_boundary(q_start=q, v_start=v))
    np.testing.assert_allclose(u, from_v.trajectory.u[0], rtol=0, atol=1e-6)


def test_the_step_time_counts_the_work_around_the_solve(monkeypatch):
    """With 50 ms spent in the step outside IPOPT (a pause before the solve), the recorded
    step time is at least the solve time plus 50 ms, and at most the wall time of the
    call measured here."""
    def paused(problem, **keywords):
        time.sleep(0.05)
        return solve(problem, **keywords)
    monkeypatch.setattr(mpc, "solve", paused)
    controller = dmoc.MPC(parking(steps=6))
    tic = time.perf_counter()
    controller.step(np.zeros(3), p=np.zeros(3))
    wall = time.perf_counter() - tic
    record = controller.log[0]
    assert record.solve_time > 0 and record.solve_time + 0.05 <= record.step_time <= wall


def test_a_free_time_step_records_its_h_and_a_plant_at_that_h_follows_the_plan():
    """With a free final time each solve chooses h = T / N: the record's h is the plan's
    (its t_1 - t_0), two steps choose different ones, and a plant equal to the model
    re-discretized at the record's h (`disc.with_step`) lands on the plan's q_1, p_1; at
    the discretization's own h it does not."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    problem = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                         duration=(1.0, 4.0),
                                         running_cost=lambda q, v, u: 1.0 + u[0] ** 2 + u[1] ** 2)
    controller = dmoc.MPC(problem)
    q, p, steps = np.zeros(3), np.zeros(3), []
    for k in range(2):
        u = controller.step(q, p=p)
        plan, h = controller.plan.trajectory, controller.log[-1].h
        assert h == pytest.approx(plan.t[1] - plan.t[0], rel=1e-12) and h != disc.h
        run = dmoc.simulate(disc.with_step(h), q0=q, p0=p, steps=1, controls=u[None], jit=False)
        np.testing.assert_allclose(run.trajectory.q[-1], plan.q[1], rtol=0, atol=1e-9)
        at_own_h = dmoc.simulate(disc, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        assert np.abs(at_own_h.trajectory.q[-1] - plan.q[1]).max() > 1e-4
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        steps.append(h)
    assert steps[0] != steps[1]
