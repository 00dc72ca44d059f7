"""dmoc.MPC, the receding-horizon controller.

Oracles, none from the controller itself: the cold solve of the same problem statement
from the default guess (each warm-started step must reach its optimum), the same start
given by its velocity (the first plan must be the optimum of `optimize` from (q, v)), and
the simulator (`dmoc.simulate` of the applied controls, from the measured state, must land
on the plan's q_1, p_1: both solve the same step residual).
"""

import numpy as np
import pytest

import dmoc
from dmoc.optimize.mpc import shifted


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
