"""DMOC with the Lobatto stage rules and controls at the stage nodes: the optimal cost and
the final state of the optimal controls re-simulated by DOP853 on the continuous reduced
equations (written here, u(t) from `Trajectory.control`) converge at the rule's order;
`simulate` with the same rule replays the optimum; one control held per step falls back to
order 2 (Campos, Ober-Bloebaum & Trelat 2015)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc.discrete import QuadratureRule
from dmoc.problems import knife_edge_parking, rolling_disk_steering

# Continuous optima (Hermite-Simpson at N = 3200, IPOPT tol 1e-13, Richardson-checked to
# 1e-13; benchmarks/dmoc_vs_collocation.py prints them).
J_REF = {"knife": 8.72240586430046, "disk": 1.02891883210778}
MAKE = {"knife": knife_edge_parking, "disk": rolling_disk_steering}
STEPS = (20, 40, 80, 160)


def knife_rhs(z, u):
    """m = J = 1: (x, y, theta, sigma, omega)' with sigma the speed along the blade."""
    return [z[3] * math.cos(z[2]), z[3] * math.sin(z[2]), z[4], u[0], u[1]]


def disk_rhs(z, u):
    """m = R = 1, I = 1/2, J = 1/4: (x, y, theta, phi, theta', phi')'."""
    return [math.cos(z[3]) * z[4], math.sin(z[3]) * z[4], z[4], z[5], u[0] / 1.5, u[1] / 0.25]


RHS = {"knife": (knife_rhs, 5), "disk": (disk_rhs, 6)}


def resimulated_final_configuration(name, traj):
    """q(T) of the continuous equations driven by u(t) = traj.control(t), from rest at
    traj.q[0]; DOP853 step by step (u is smooth within each step)."""
    rhs, size = RHS[name]
    z = np.zeros(size)
    z[: traj.q.shape[1]] = traj.q[0]
    for k in range(traj.steps):
        sol = solve_ivp(lambda t, y: rhs(y, traj.control(t)), (traj.t[k], traj.t[k + 1]), z,
                        method="DOP853", rtol=1e-13, atol=1e-13)
        z = sol.y[:, -1]
    return z[: traj.q.shape[1]]


def goal_error(name, problem, traj):
    q_T = resimulated_final_configuration(name, traj)
    given = np.isfinite(problem.q_goal)
    return np.abs(q_T[given] - problem.q_goal[given]).max()


def slope(errors):
    return -np.polyfit(np.log(STEPS), np.log(errors), 1)[0]


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("name", ["knife", "disk"])
def test_lobatto3_dmoc_converges_at_order_four_and_replays(name, variant):
    cost_errors, goal_errors = [], []
    for N in STEPS:
        problem = MAKE[name](N, variant=variant, rule="lobatto3")
        result = dmoc.optimize(problem)
        traj = result.trajectory
        assert traj.u.shape == (N, 6) and traj.control_nodes == (0.0, 0.5, 1.0)
        cost_errors.append(abs(result.cost - J_REF[name]))
        goal_errors.append(goal_error(name, problem, traj))
        replay = dmoc.simulate(problem.disc, q0=traj.q[0], p0=traj.p[0], steps=N,
                               controls=traj.u, variant=variant).trajectory
        last = N + (variant == "+")       # (-): p_N holds the end impulse
        assert np.abs(replay.q - traj.q).max() < 1e-8
        assert np.abs(replay.p[:last] - traj.p[:last]).max() < 1e-8
    assert slope(cost_errors) > 3.65, cost_errors
    assert slope(goal_errors) > 3.65, goal_errors


def test_lobatto4_dmoc_cost_converges_at_order_six():
    steps = (10, 20, 40)
    errors = [abs(dmoc.optimize(knife_edge_parking(N, rule="lobatto4")).cost - J_REF["knife"])
              for N in steps]
    assert -np.polyfit(np.log(steps), np.log(errors), 1)[0] > 5.5, errors


def test_one_control_held_per_step_falls_back_to_order_two():
    """The same Galerkin rule with a single control per step (control node 1/2)."""
    held = QuadratureRule("lobatto3-held", 4, (0.0, 0.5, 1.0),
                          ((0.0, 1 / 6), (0.5, 2 / 3), (1.0, 1 / 6)), control_nodes=(0.5,))
    errors = [abs(dmoc.optimize(knife_edge_parking(N, rule=held)).cost - J_REF["knife"])
              for N in STEPS]
    assert abs(slope(errors) - 2) < 0.35, errors


def test_guess_from_a_midpoint_optimum_on_another_grid():
    """A second-order optimum on a coarser grid warm-starts a Lobatto problem (controls
    resampled through Trajectory.control, stages put on the chords) to the same optimum."""
    coarse = dmoc.optimize(knife_edge_parking(25)).trajectory
    problem = knife_edge_parking(40, rule="lobatto3")
    cold, warm = dmoc.optimize(problem), dmoc.optimize(problem, guess=coarse)
    assert abs(warm.cost - cold.cost) < 1e-9
    assert np.abs(warm.trajectory.q - cold.trajectory.q).max() < 1e-7
