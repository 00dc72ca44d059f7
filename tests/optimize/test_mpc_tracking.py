"""A tracking MPC: the reference (a planned trajectory and its controls) as parameters per
knot and per step of the horizon, moved on by one step at each controller step without a
new NLP.

Oracles: the plan's own final state (the closed loop of examples/mpc_tracking.py on a plant
20 % heavier ends within 1 cm of it, the plan replayed open loop on that plant ends tens of
cm away, and the LQR gains of `dmoc.tvlqr` bring it ten times closer); the windows cut by
hand and passed as `parameters=` give bit for bit the controls of `references=`.
"""

import importlib.util
import pathlib

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.errors import InputError
from dmoc.problems import knife_edge_parking

N, HORIZON = 40, 10
EXAMPLES = pathlib.Path(__file__).parents[2] / "examples"


@pytest.fixture(scope="module")
def plan():
    return dmoc.optimize(knife_edge_parking(N)).trajectory


def tracking(plan, **extra):
    """Knife-edge tracking over HORIZON steps, the end free, weights 1e4 on q."""
    return dmoc.OptimalControlProblem(
        knife_edge_parking(N).disc, HORIZON, q_start=plan.q[0], q_goal=[None] * 3, v_goal=[None] * 3,
        parameters={"q_ref": plan.q[:HORIZON + 1], "u_ref": plan.u[:HORIZON], **extra},
        running_cost=lambda q, v, u, w: 1e4 * ca.sumsqr(q - w["q_ref"]) + ca.sumsqr(u - w["u_ref"]),
        terminal_cost=lambda q, v, w: 1e4 * ca.sumsqr(q - w["q_ref"]))


def closed_loop(controller, plant, plan, steps, **step):
    q, p, controls = plan.q[0], plan.p[0], []
    for k in range(steps):
        u = controller.step(q, p=p, **{key: f(k) for key, f in step.items()})
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        controls.append(u)
    return q, np.array(controls)


def test_tracking_a_plan_on_a_heavier_plant_ends_within_a_centimetre(tmp_path):
    """examples/mpc_tracking.py: the plan followed on a plant 20 % heavier."""
    spec = importlib.util.spec_from_file_location("mpc_tracking", EXAMPLES / "mpc_tracking.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    plan, paths, log = example.main(steps=N + 10, out=tmp_path)
    miss = {name: np.linalg.norm(path.q[-1] - plan.q[-1]) for name, path in paths.items()}
    assert miss["tracking MPC"] < 0.01 and miss["open loop"] > 0.1
    assert miss["LQR gains"] < miss["open loop"] / 10
    assert all(r.success for r in log) and all(r.warm_start for r in log[1:])
    assert (tmp_path / "mpc_tracking_paths.png").stat().st_size > 1000


def test_references_are_the_windows_a_caller_would_cut(plan):
    """`references=` and windows cut in the test, passed as `parameters=` at each step,
    give the same controls bit for bit (one code path: `with_parameters`); the clock
    moves on by the applied h."""
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.2, inertia=1.2), plan.h)
    q_ref = np.vstack([plan.q, np.repeat(plan.q[-1:], HORIZON, axis=0)])
    u_ref = np.vstack([plan.u, np.repeat(plan.u[-1:], HORIZON, axis=0)])
    given = dmoc.MPC(tracking(plan, t=2.0), references={"q_ref": plan.q, "u_ref": plan.u})
    _, u_given = closed_loop(given, plant, plan, 4)
    cut = dmoc.MPC(tracking(plan, t=2.0))
    _, u_cut = closed_loop(cut, plant, plan, 4, parameters=lambda k: {
        "q_ref": q_ref[k:k + HORIZON + 1], "u_ref": u_ref[k:k + HORIZON]})
    np.testing.assert_array_equal(u_given, u_cut)
    np.testing.assert_allclose(given.problem.parameter_values["t"], 2.0 + 3 * plan.h, rtol=1e-15)


def test_bad_references_are_refused_by_name(plan):
    problem = tracking(plan, r=1.0)
    with pytest.raises(InputError, match=r"`references` names parameters given per step or per knot.*'r'"):
        dmoc.MPC(problem, references={"r": np.ones((5, 1))})
    with pytest.raises(InputError, match=r"references\['q_ref'\]` must be a finite array of shape \(M, 3\)"):
        dmoc.MPC(problem, references={"q_ref": np.ones((5, 2))})
    controller = dmoc.MPC(problem, references={"q_ref": plan.q})
    with pytest.raises(InputError, match=r"MPC step 0: `parameters` must not set \['q_ref'\]"):
        controller.step(plan.q[0], p=plan.p[0], parameters={"q_ref": plan.q[:HORIZON + 1]})
    with pytest.raises(InputError, match=r"MPC step 0: .*parameters\['u_ref'\]` must be shape \(10, 2\)"):
        controller.step(plan.q[0], p=plan.p[0], parameters={"u_ref": plan.u})
