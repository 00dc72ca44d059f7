"""DMOC on SO(3) x R^3: the quadrotor (`dmoc.systems.quadrotor`) moved between two hover
states (at rest, R = I, the thrust m g) with the least sum h |u|^2, judged by oracles
written here: its controls, held on each step, integrated by DOP853 on the reduced
equations m x'' = f R e3 - m g e3, R' = R Omega^, J Omega' = J Omega x Omega + tau land on
the goal hover to O(h^2), the optimal cost converges at order 2, and the optimum replays in
the simulator (verdict passed).

The inertia is large against m g (sqrt(J / (m g)) ~ 0.25 s against T = 2 s): about hover
the cost is m^2 g^2 T + m^2 g^2 |tilt|^2 + |tau|^2 to second order (the vertical balance
turns the extra thrust into the tilt squared), so a small J gives the optimum boundary
layers of width sqrt(J / (m g)) at both ends, which these coarse grids would not resolve.
"""

import numpy as np
from scipy.integrate import solve_ivp

import dmoc

MASS, INERTIA, GRAVITY, T = 1.0, np.array([0.5, 0.6, 0.9]), 9.81, 2.0
E3 = np.array([0.0, 0.0, 1.0])
X_START, X_GOAL = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.5, 1.5])


def reduced(t, z, u):
    """The equations above with u = (f, tau) held, z = (rows of R, x, x', Omega)."""
    R, v, Omega = z[:9].reshape(3, 3), z[12:15], z[15:]
    Omega_hat = np.array([[0, -Omega[2], Omega[1]], [Omega[2], 0, -Omega[0]],
                          [-Omega[1], Omega[0], 0]])
    dv = u[0] / MASS * R @ E3 - GRAVITY * E3
    dOmega = (np.cross(INERTIA * Omega, Omega) + u[1:]) / INERTIA
    return np.concatenate([(R @ Omega_hat).ravel(), v, dv, dOmega])


def landing_error(controls, h):
    """max |R(T) - I|, |x(T) - x_goal|, |x'(T)|, |Omega(T)| of DOP853 run step by step with
    the controls held."""
    z = np.concatenate([np.eye(3).ravel(), X_START, np.zeros(6)])
    for u in controls:
        z = solve_ivp(reduced, (0.0, h), z, args=(u,), method="DOP853", rtol=1e-12,
                      atol=1e-12).y[:, -1]
    return np.abs(z - np.concatenate([np.eye(3).ravel(), X_GOAL, np.zeros(6)])).max()


def test_dmoc_moves_the_quadrotor_between_hover_states_at_order_2():
    body = dmoc.systems.quadrotor(MASS, INERTIA, GRAVITY)
    errors, costs, steps = [], [], [20, 40, 80]
    for N in steps:
        problem = dmoc.GroupOptimalControlProblem(
            dmoc.discretize(body, T / N), N, R_start=np.eye(3), R_goal=np.eye(3),
            x_start=X_START, x_goal=X_GOAL)
        result = dmoc.optimize(problem)
        assert result.success and result.stats["replay_deviation"] <= 1e-10
        traj = result.trajectory
        assert np.abs(traj.R[-1] - np.eye(3)).max() <= 1e-10
        assert np.abs(traj.x[-1] - X_GOAL).max() <= 1e-10
        assert np.abs(traj.p[[0, -1]]).max() <= 1e-10          # at rest at both ends
        assert traj.orthogonality_defect.max() <= 1e-13
        errors.append(landing_error(traj.u, T / N))
        costs.append(result.cost)
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(orders - 2) <= 0.25), orders
    assert 3.5 <= (costs[0] - costs[1]) / (costs[1] - costs[2]) <= 4.7, costs
    # a test of the test: it tilts (the thrust turns to move it sideways) and it hovers
    # near f = m g, whose share m^2 g^2 T dominates the cost
    assert np.abs(traj.R[:, :2, 2]).max() > 0.05
    assert np.abs(traj.u[:, 0] / (MASS * GRAVITY) - 1).max() < 0.2
    assert abs(costs[-1] / (MASS * GRAVITY) ** 2 / T - 1) < 0.05
