"""dmoc.MPC on SO(3) x R^2: the Chaplygin sphere rolled to a goal by a controller that
models it wrongly and measures it with noise.

Oracles, none from the controller: the plant is the sphere's reduced equations written
here (R' = R Omega^, (J + m A^T A) Omega' = J Omega x Omega + u with A = r P e3^ R, and
x' = r P (R Omega x e3): the Euler-Poincare equations with the rolling multiplier
eliminated), heavier than the model and integrated by scipy's DOP853 with each control
held over its step; the measurement policy is checked against the nearest rotation
computed here from scipy's polar decomposition and against the rolling rows evaluated here.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import polar
from scipy.spatial.transform import Rotation

import dmoc
from dmoc.errors import InputError

INERTIA, MASS, RADIUS = np.array([1.0, 1.5, 2.5]), 1.3, 0.7
GOAL_R = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()
GOAL_X = np.array([1.0, 0.5])
P_E3_HAT = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])      # the first two rows of e3^


def hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def rolling_rows(R, r=RADIUS):
    """A_Omega = r P e3^ R of the rolling x' = -A_Omega Omega, shape (2, 3)."""
    return r * P_E3_HAT @ R


def plant_step(R, Omega, x, u, h, J, m, r=RADIUS):
    """(R, Omega, x) after h under the held body torque u: DOP853 on the reduced equations."""
    def rhs(t, y):
        R, W = y[:9].reshape(3, 3), y[9:12]
        A = rolling_rows(R, r)
        dW = np.linalg.solve(np.diag(J) + m * A.T @ A, np.cross(J * W, W) + u)
        return np.concatenate([(R @ hat(W)).ravel(), dW, -A @ W])
    y = solve_ivp(rhs, (0.0, h), np.concatenate([R.ravel(), Omega, x]), method="DOP853",
                  rtol=1e-11, atol=1e-12).y[:, -1]
    R = polar(y[:9].reshape(3, 3))[0]           # the integrator's drift off SO(3), ~1e-11
    return R, y[9:12], y[12:]


def rolling_problem(steps=10, h=0.2):
    body = dmoc.systems.chaplygin_sphere(INERTIA, MASS, RADIUS, torques=True)
    return dmoc.GroupOptimalControlProblem(dmoc.discretize(body, h), steps, R_start=np.eye(3),
                                           R_goal=GOAL_R, x_start=[0.0, 0.0], x_goal=GOAL_X)


def test_a_noisy_closed_loop_on_a_heavier_sphere_rolls_it_to_the_goal():
    """50 steps of h = 0.2 s on a plant 20 % heavier in J and m, measured with noise (1e-4
    on each entry of R, so R is off SO(3), and on x; 1e-3 on Omega and x', so the velocity
    slips): every step returns controls and logs its status and the projection it made
    (rotation and velocity), each start is a rotation with a rolling velocity, and the
    plant ends within 3 cm and 0.04 rad of the goal, nearly at rest, where the first plan's
    controls run open loop on the same plant miss it by more than 0.1 m. (The sphere is
    nonholonomic: correcting a small error takes a manoeuvre of its square root, so noise
    keeps it moving near the goal; without noise it ends within 5e-4.)"""
    controller = dmoc.MPC(rolling_problem())
    rng = np.random.default_rng(3)
    R, Omega, x = np.eye(3), np.zeros(3), np.zeros(2)
    for _ in range(50):
        v = np.concatenate([Omega, -rolling_rows(R) @ Omega])
        u = controller.step((R + 1e-4 * rng.normal(size=(3, 3)), x + 1e-4 * rng.normal(size=2)),
                            v=v + 1e-3 * rng.normal(size=5))
        assert u.shape == (3,) and np.isfinite(u).all()
        R, Omega, x = plant_step(R, Omega, x, u, 0.2, 1.2 * INERTIA, 1.2 * MASS)
    log = controller.log
    assert len(log) == 50 and all(s.success and s.status == "Solve_Succeeded" for s in log)
    assert all(s.corrected == ("rotation", "velocity") for s in log)
    assert not log[0].warm_start and all(s.warm_start for s in log[1:])
    for s in log:
        R0 = s.q[:9].reshape(3, 3)
        assert np.abs(R0.T @ R0 - np.eye(3)).max() <= 1e-14
        R_m = s.q_measured[:9].reshape(3, 3)
        assert np.abs(polar(R_m)[0] - R0).max() <= 1e-14            # the nearest rotation
        assert s.q_correction == pytest.approx(np.linalg.norm(R_m - R0), abs=1e-15)
        Omega0 = s.p[:3] / INERTIA
        assert np.abs(s.p[3:] / MASS + rolling_rows(R0) @ Omega0).max() <= 1e-14
    angle = np.linalg.norm(Rotation.from_matrix(GOAL_R.T @ R).as_rotvec())
    assert np.linalg.norm(x - GOAL_X) <= 0.03 and angle <= 0.04 and np.abs(Omega).max() <= 0.03
    R, Omega, x = np.eye(3), np.zeros(3), np.zeros(2)
    for u in dmoc.optimize(rolling_problem()).trajectory.u:
        R, Omega, x = plant_step(R, Omega, x, u, 0.2, 1.2 * INERTIA, 1.2 * MASS)
    assert np.linalg.norm(x - GOAL_X) > 0.1


def test_bad_measurements_name_the_step_and_the_entry_and_refuse_names_the_rotation():
    controller = dmoc.MPC(rolling_problem(steps=4))
    v0 = np.zeros(5)
    controller.step((np.eye(3), np.zeros(2)), v=v0)
    R = np.eye(3)
    R[1, 2] = np.nan
    with pytest.raises(InputError, match=r"MPC step 1: `q\[0\] \(R\)` must be finite; entry \(1, 2\)"):
        controller.step((R, np.zeros(2)), v=v0)
    with pytest.raises(InputError, match=r"MPC step 1: `q\[1\] \(x\)` must have shape \(2,\)"):
        controller.step((np.eye(3), np.zeros(3)), v=v0)
    with pytest.raises(InputError, match=r"MPC step 1: `q` must be the pair \(R, x\)"):
        controller.step(np.eye(3), v=v0)
    with pytest.raises(InputError, match=r"MPC step 1: `v` must have shape \(5,\)"):
        controller.step((np.eye(3), np.zeros(2)), v=np.zeros(3))
    with pytest.raises(InputError, match="exactly one"):
        controller.step((np.eye(3), np.zeros(2)), v=v0, p=v0)
    assert len(controller.log) == 1                        # nothing recorded
    strict = dmoc.MPC(rolling_problem(steps=4), measurement="refuse")
    with pytest.raises(InputError, match=r"MPC step 0: .*rotation: \|R\^T R - I\| = 2\.001e-03"):
        strict.step((np.diag([1.001, 1.0, 1.0]), np.zeros(2)), v=v0)
    with pytest.raises(InputError, match=r"MPC step 0: .*velocity: max abs\(A\(q\) v\) = 7\.000e-01"):
        strict.step((np.eye(3), np.zeros(2)), v=[1.0, 0, 0, 0, 0])
    unjudged = dmoc.optimize(rolling_problem(steps=4), check=False)    # a coarse plan: any result
    for name, value in (("guess", unjudged), ("references", {"t": [[0.0]]}), ("jit", True)):
        with pytest.raises(InputError, match=f"`{name}` is not taken by MPC of a GroupOptimalControlProblem"):
            dmoc.MPC(rolling_problem(steps=4), **{name: value})
    with pytest.raises(InputError, match="`parameters` must be None"):
        controller.step((np.eye(3), np.zeros(2)), v=v0, parameters={"a": 1.0})


def test_the_warm_start_moves_each_rotation_by_its_increment_and_carries_the_plan_to_the_start():
    """The shifted optimum (`dmoc.drivers.horizon_shift.shifted_on_group`) from a start
    D R_1 (D a small rotation), x_1 + d: its knots are D R_{k+1}, x_{k+1} + d, the last
    continues the last increment, R'_N = R'_{N-1} cay(f_{N-1}), so that every group row
    R'_{k+1} = R'_k cay(f'_k) holds at round-off (Cayley written here)."""
    from dmoc.drivers.horizon_shift import shifted_on_group
    from dmoc.optimal_control.nlp.group_transcription import group_transcription

    problem = rolling_problem(steps=6)
    plan, T = dmoc.optimize(problem), group_transcription(problem)
    D, d = Rotation.from_rotvec([0.01, -0.02, 0.03]).as_matrix(), np.array([0.003, -0.004])
    traj = plan.trajectory
    start = np.concatenate([(D @ traj.R[1]).ravel(), traj.x[1] + d])
    x0 = shifted_on_group(plan, T, 6, 1, start)["x0"]
    q, f = T.x_layout.unpack(x0, "q").T, T.x_layout.unpack(x0, "f").T
    R, x = q[:, :9].reshape(-1, 3, 3), q[:, 9:]

    def cay(w):
        W = hat(w)
        return np.eye(3) + 4 / (4 + w @ w) * (W + W @ W / 2)
    assert np.abs(R[:6] - D @ traj.R[1:]).max() <= 1e-15 and np.abs(x[:6] - traj.x[1:] - d).max() <= 1e-15
    assert np.abs(f[:5] - traj.f[1:]).max() == 0 and np.abs(f[5] - traj.f[5]).max() == 0
    for k in range(6):
        assert np.abs(R[k + 1] - R[k] @ cay(f[k, :3])).max() <= 1e-14
        assert np.abs(x[k + 1] - x[k] - f[k, 3:]).max() <= 1e-15


def test_after_a_failed_solve_the_plan_is_followed_and_the_next_warm_start_moves_two_steps(monkeypatch):
    """on_failure="shift" on the group: step 1's solve is made to fail, so its controls are
    the step-0 plan's u_1 (plan_age 1), and step 2 starts from that plan moved 2 steps on
    (its first knot free of the start: R_2, x_2 of the plan carried onto the measurement)."""
    from dmoc.drivers import group_horizon

    calls, real = [], group_horizon.solve_with

    def failing_second(problem, T, solver, start, **keywords):
        result = real(problem, T, solver, start, **keywords)
        calls.append(start)
        if len(calls) == 2:
            result.success, result.status = False, "Maximum_Iterations_Exceeded"
        return result
    monkeypatch.setattr(group_horizon, "solve_with", failing_second)
    controller = dmoc.MPC(rolling_problem(steps=6), on_failure="shift")
    controller.step((np.eye(3), np.zeros(2)), v=np.zeros(5))
    plan = controller.plan.trajectory
    u = controller.step((plan.R[1], plan.x[1]), p=plan.p[1])
    assert np.array_equal(u, plan.u[1]) and controller.log[1].plan_age == 1 and not controller.log[1].success
    controller.step((plan.R[2], plan.x[2]), p=plan.p[2])
    x0 = calls[2]["x0"]
    q = x0[:11 * 7].reshape(7, 11)
    np.testing.assert_allclose(q[:5, :9], plan.R[2:7].reshape(5, 9), rtol=0, atol=1e-15)
    np.testing.assert_allclose(q[:5, 9:], plan.x[2:7], rtol=0, atol=1e-15)
    assert controller.log[2].success and controller.log[2].plan_age == 0


def test_a_spacecraft_slewed_on_a_finer_heavier_plant_ends_on_the_eigenaxis_goal():
    """A body with a fixed point (n_x = 0; q is R alone): a spacecraft with I = 2 slewed by
    1 rad about (1, 2, 2)/3 over a 2 s horizon of h = 0.2 s, the plant I = 2.3 stepped by
    `dmoc.simulate` with its own h/4 (each control held over 4 of its steps), R measured
    with noise and p exactly: after 40 steps the plant is within 1e-3 rad of the goal and
    at rest to 1e-3 rad/s (the terminal constraint recedes with the horizon, so the loop
    closes slowly: 1.3e-3 rad and 2.8e-3 rad/s after 25 steps), where the first plan run
    open loop on the plant stops short by more than 0.05 rad; every start a rotation of 9
    entries. A wrong shape names R."""
    axis, I = np.array([1.0, 2.0, 2.0]) / 3, 2.0
    goal = Rotation.from_rotvec(axis).as_matrix()
    slew = dmoc.GroupOptimalControlProblem(dmoc.discretize(dmoc.systems.spacecraft((I, I, I)), 0.2), 10,
                                           R_start=np.eye(3), R_goal=goal)
    plant = dmoc.discretize(dmoc.systems.spacecraft((1.15 * I,) * 3), 0.05)
    controller, rng = dmoc.MPC(slew), np.random.default_rng(7)
    R, Pi = np.eye(3), np.zeros(3)
    for _ in range(40):
        u = controller.step(R + 1e-5 * rng.normal(size=(3, 3)), p=Pi)
        run = dmoc.simulate(plant, q0=R, p0=Pi, steps=4, controls=np.repeat(u[None], 4, axis=0)).trajectory
        R, Pi = run.R[-1], run.Pi[-1]
    assert all(s.success and s.q.shape == (9,) and s.corrected == ("rotation",) for s in controller.log)
    assert np.linalg.norm(Rotation.from_matrix(goal.T @ R).as_rotvec()) <= 1e-3
    assert np.abs(Pi / (1.15 * I)).max() <= 1e-3
    open_loop = dmoc.simulate(plant, q0=np.eye(3), p0=np.zeros(3), steps=40,
                              controls=np.repeat(dmoc.optimize(slew).trajectory.u, 4, axis=0)).trajectory
    assert np.linalg.norm(Rotation.from_matrix(goal.T @ open_loop.R[-1]).as_rotvec()) > 0.05
    with pytest.raises(InputError, match=r"MPC step 40: `q` must have shape \(3, 3\)"):
        controller.step(R.ravel(), p=Pi)
