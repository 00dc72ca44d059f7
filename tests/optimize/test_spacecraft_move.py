"""DMOC on SE(3): a spacecraft with equal principal moments I and mass m
(`dmoc.systems.spacecraft(inertia, mass)`), driven by body-fixed thrusters (a body torque
tau and a body force F), moved by d and turned by theta about a fixed axis between two
rest poses in time T with the least integral of |tau|^2 + |F|^2. Oracles written here:

- since |R F| = |F|, the cost splits into the rotation under tau (the eigenaxis slew,
  12 I^2 theta^2 / T^3) and the translation under the spatial force R F (the straight
  move with x(t) cubic, 12 m^2 |d|^2 / T^3): J* = 12 (I^2 theta^2 + m^2 |d|^2) / T^3,
  which the discrete optimum reaches at order 2;
- its controls, held on each step, integrated by DOP853 on the reduced equations
  J Omega' = J Omega x Omega + tau, R' = R Omega^, m x'' = R F, land on the goal at rest
  to O(h^2);
- the optimum replays in the simulator (verdict passed).
"""

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import dmoc

I, MASS, T, THETA = 2.0, 1.5, 2.0, 1.2
AXIS = np.array([1.0, 2.0, 2.0]) / 3
D = np.array([1.0, -0.5, 0.3])
R_GOAL = Rotation.from_rotvec(THETA * AXIS).as_matrix()


def reduced(t, z, u):
    """The equations above with u = (tau, F) held, z = (rows of R, x, x', Omega)."""
    R, v, Omega = z[:9].reshape(3, 3), z[12:15], z[15:]
    Omega_hat = np.array([[0, -Omega[2], Omega[1]], [Omega[2], 0, -Omega[0]],
                          [-Omega[1], Omega[0], 0]])
    return np.concatenate([(R @ Omega_hat).ravel(), v, R @ u[3:] / MASS, u[:3] / I])


def landing_error(controls, h):
    """max |R(T) - R_goal|, |x(T) - d|, |x'(T)|, |Omega(T)| of DOP853 run step by step."""
    z = np.concatenate([np.eye(3).ravel(), np.zeros(9)])
    for u in controls:
        z = solve_ivp(reduced, (0.0, h), z, args=(u,), method="DOP853", rtol=1e-12,
                      atol=1e-12).y[:, -1]
    return np.abs(z - np.concatenate([R_GOAL.ravel(), D, np.zeros(6)])).max()


def test_move_and_turn_between_rest_poses_at_order_2():
    body = dmoc.systems.spacecraft((I, I, I), mass=MASS)
    best = 12 * (I ** 2 * THETA ** 2 + MASS ** 2 * D @ D) / T ** 3
    costs, landings, steps = [], [], [10, 20, 40]
    for N in steps:
        problem = dmoc.GroupOptimalControlProblem(
            dmoc.discretize(body, T / N), N, R_start=np.eye(3), R_goal=R_GOAL,
            x_start=np.zeros(3), x_goal=D)
        result = dmoc.optimize(problem)
        assert result.success and result.verdict.status == "passed", result.message
        assert result.stats["replay_deviation"] <= 1e-10
        traj = result.trajectory
        assert np.abs(traj.R[-1] - R_GOAL).max() <= 1e-10 and np.abs(traj.x[-1] - D).max() <= 1e-10
        assert np.abs(traj.p[[0, -1]]).max() <= 1e-10
        costs.append(result.cost)
        landings.append(landing_error(traj.u, T / N))
    errors = np.array(costs) - best
    assert np.all(errors > 0)
    assert np.all(np.abs(np.log2(errors[:-1] / errors[1:]) - 2) <= 0.2), errors
    assert np.all(np.abs(np.log2(np.array(landings[:-1]) / landings[1:]) - 2) <= 0.3), landings
    # a test of the test: both parts of the cost count (neither share is small)
    assert min(I ** 2 * THETA ** 2, MASS ** 2 * D @ D) / (I ** 2 * THETA ** 2 + MASS ** 2 * D @ D) > 0.3
