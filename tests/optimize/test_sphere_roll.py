"""DMOC on SO(3) x R^2: the Chaplygin sphere (`dmoc.systems.chaplygin_sphere(torques=True)`)
rolled by body torques to a goal position and orientation, judged by oracles written here:
the goal, the rolling x_{k+1} - x_k = r P ((R_k f_k) x e3) at every step with f_k the
Cayley coordinates of R_k^T R_{k+1} (tests/simulate/test_chaplygin_sphere.py), and the
replay in the simulator."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc

INERTIA, MASS, RADIUS = np.array([1.0, 1.5, 2.5]), 1.3, 0.7
E3 = np.array([0.0, 0.0, 1.0])


def cayley_inverse(F):
    """2 vee(F - F^T)/(1 + tr F)."""
    A = F - F.T
    return 2 * np.array([A[2, 1], A[0, 2], A[1, 0]]) / (1 + np.trace(F))


def test_dmoc_rolls_the_sphere_to_a_goal_position_and_orientation():
    """Rest to rest, from (I, 0) to a quarter turn about e3 at (1, 0.5) in 4 s with the least
    sum h |u|^2: the optimum meets the goal, rolls at every step (the check above, from the
    rotations) and replays in the simulator (verdict passed)."""
    body = dmoc.systems.chaplygin_sphere(INERTIA, MASS, RADIUS, torques=True)
    goal = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()
    problem = dmoc.GroupOptimalControlProblem(dmoc.discretize(body, 0.2), 20, R_start=np.eye(3),
                                              R_goal=goal, x_start=[0.0, 0.0], x_goal=[1.0, 0.5])
    result = dmoc.optimize(problem)
    assert result.success and result.stats["replay_deviation"] <= 1e-10
    traj = result.trajectory
    assert np.abs(traj.R[-1] - goal).max() <= 1e-10 and np.abs(traj.x[-1] - [1.0, 0.5]).max() <= 1e-10
    f = np.array([cayley_inverse(a.T @ b) for a, b in zip(traj.R[:-1], traj.R[1:])])
    rolled = RADIUS * np.cross(np.einsum("kij,kj->ki", traj.R[:-1], f), E3)[:, :2]
    assert np.abs(np.diff(traj.x, axis=0) - rolled).max() <= 1e-10
    assert traj.orthogonality_defect.max() <= 1e-13 and np.abs(traj.Pi[0]).max() == 0.0
    assert result.cost > 0.1 and np.abs(traj.lam).max() > 1e-3


def test_dmoc_refuses_missing_coordinates_and_velocities_that_slip():
    disc = dmoc.discretize(dmoc.systems.chaplygin_sphere(torques=True), 0.1)
    with pytest.raises(ValueError, match="x_goal"):
        dmoc.GroupOptimalControlProblem(disc, 10, R_start=np.eye(3), R_goal=np.eye(3), x_start=[0, 0])
    with pytest.raises(ValueError, match="constraints"):
        dmoc.GroupOptimalControlProblem(disc, 10, R_start=np.eye(3), R_goal=np.eye(3), x_start=[0, 0],
                                        x_goal=[1, 0], omega_start=[0.0, 1.0, 0.0])


def test_the_geodesic_guess_starts_from_zero_multipliers_without_their_estimate(monkeypatch):
    """From the geodesic guess (zero controls, so the cost h sum |u|^2 has zero gradient)
    the least-squares multipliers of the equality rows are zero: the solve skips IPOPT's
    estimate (`group_solving.GUESS_OPTIONS`) for the same iterates and optimum bit for bit
    as IPOPT's default estimate gives. A problem with path constraints (inequality rows,
    whose slacks' bound multipliers enter the estimate) keeps it. Both take the KKT
    solutions without IPOPT's iterative refinement (`GUESS_OPTIONS`): the same iterations
    and optimum to round-off as with it."""
    from dmoc.optimal_control.solver import group_solving
    body = dmoc.systems.chaplygin_sphere(INERTIA, MASS, RADIUS, torques=True)
    goal = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()
    ends = dict(R_start=np.eye(3), R_goal=goal, x_start=[0.0, 0.0], x_goal=[1.0, 0.5])
    problem = dmoc.GroupOptimalControlProblem(dmoc.discretize(body, 0.4), 10, **ends)
    given, real = [], group_solving.solve_with

    def recorded(problem, T, options, start, **keywords):
        given.append(options)
        return real(problem, T, options, start, **keywords)
    monkeypatch.setattr(group_solving, "solve_with", recorded)
    skipped = group_solving.solve_on_group(problem)
    estimated = group_solving.solve_on_group(problem, options={"constr_mult_init_max": 1e3})
    assert given[0]["constr_mult_init_max"] == 0.0 and given[1]["constr_mult_init_max"] == 1e3
    assert skipped.stats["iterations"] == estimated.stats["iterations"]
    assert np.array_equal(skipped.x, estimated.x) and np.array_equal(skipped.lam_g, estimated.lam_g)
    refined = group_solving.solve_on_group(problem, options={"fast_step_computation": "no"})
    assert given[0]["fast_step_computation"] == "yes"
    assert refined.stats["iterations"] == skipped.stats["iterations"]
    assert np.abs(refined.x - skipped.x).max() <= 1e-12 and abs(refined.cost - skipped.cost) <= 1e-12
    fenced = dmoc.GroupOptimalControlProblem(dmoc.discretize(body, 0.4), 10, **ends,
                                             path_constraints=lambda R, x, u: x[1] - 2.0)
    group_solving.solve_on_group(fenced)
    assert "constr_mult_init_max" not in given[3] and given[3]["fast_step_computation"] == "yes"
