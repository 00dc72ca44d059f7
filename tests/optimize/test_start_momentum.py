"""OptimalControlProblem(p_start=...): a problem that starts from a measured momentum, as a
receding-horizon controller must.

Oracle: the equivalence of the two statements of the same start. A state (q, p) is taken
from a simulation (its p carries the discrete constraint impulse along A(q)^T); the
velocity it stands for is written here from the knife edge's mechanics (no sideways slip:
the speed along the blade (cos theta p_x + sin theta p_y)/m, the turn rate p_theta/J), and
the problem from (q, v_start) must have the same optimum (q, u, cost) as the problem from
(q, p_start): the component of p_start along A(q_0)^T is absorbed by the first step's
multiplier (+) or by the start impulse mu (-).
"""

import numpy as np
import pytest

import dmoc

MASS, INERTIA = 2.0, 0.5


def simulated_state(variant):
    """(q, p) after 5 steps of a driven simulation of the knife edge."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=MASS, inertia=INERTIA), 0.1)
    run = dmoc.simulate(disc, q0=[0, 0, 0.2], v0=[0.5 * np.cos(0.2), 0.5 * np.sin(0.2), 0.4],
                        steps=5, controls=np.tile([0.7, -0.3], (5, 1)), variant=variant, jit=False)
    return run.trajectory.q[-1], run.trajectory.p[-1]


def allowed_velocity(q, p):
    sigma = (np.cos(q[2]) * p[0] + np.sin(q[2]) * p[1]) / MASS
    return np.array([sigma * np.cos(q[2]), sigma * np.sin(q[2]), p[2] / INERTIA])


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("rule", ["midpoint", "lobatto3"])
def test_a_start_momentum_gives_the_optimum_of_its_velocity(variant, rule):
    q, p = simulated_state(variant)
    off = -np.sin(q[2]) * p[0] + np.cos(q[2]) * p[1]
    assert abs(off) > 1e-3                          # p is not dL/dv of an allowed velocity
    disc = dmoc.discretize(dmoc.systems.knife_edge(mass=MASS, inertia=INERTIA), 0.1, rule)
    from_v = dmoc.OptimalControlProblem(disc, 30, q_start=q, q_goal=[0.5, 1.0, 0.0],
                                        v_start=allowed_velocity(q, p), variant=variant)
    from_p = from_v.with_boundary(p_start=p)
    assert from_p.velocity_rows["start"] is False and np.isnan(from_p.v_start).all()
    a, b = dmoc.optimize(from_v), dmoc.optimize(from_p)
    assert a.success and b.success
    np.testing.assert_allclose(b.cost, a.cost, rtol=1e-8)
    np.testing.assert_allclose(b.trajectory.q, a.trajectory.q, rtol=0, atol=1e-8)
    np.testing.assert_allclose(b.trajectory.u, a.trajectory.u, rtol=0, atol=1e-7)
    np.testing.assert_allclose(b.trajectory.p[0] + (b.trajectory.mu[0] * np.array(
        [-np.sin(q[2]), np.cos(q[2]), 0]) if variant == "-" else 0), p, rtol=0, atol=1e-10)


def test_with_boundary_keeps_the_nlp_of_a_momentum_start():
    problem = dmoc.problems.knife_edge_parking(20).with_boundary(p_start=[0.1, 0.0, 0.2])
    moved = problem.with_boundary(q_start=[0.1, 0.0, 0.0], p_start=[0.3, 0.0, -0.1])
    assert moved.structure == problem.structure and moved.p_start.tolist() == [0.3, 0.0, -0.1]
    assert problem.with_boundary(q_goal=[0, 2, 0]).p_start.tolist() == [0.1, 0.0, 0.2]
    back = problem.with_boundary(v_start=[0.0, 0.0, 0.0])
    assert back.p_start is None and back.structure == dmoc.problems.knife_edge_parking(20).structure
    assert not moved.p_start.flags.writeable


def test_velocity_and_momentum_at_the_start_are_exclusive():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    with pytest.raises(dmoc.InputError, match="give the start as `v_start` or as `p_start`, not both"):
        dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                   v_start=[0, 0, 0], p_start=[0, 0, 0])
    with pytest.raises(dmoc.InputError, match=r"`p_start` must have shape \(3,\)"):
        dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0], p_start=[0, 0])
    with pytest.raises(AttributeError, match=r"with_boundary\(p_start=...\)"):
        problem = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0])
        problem.p_start = [1, 0, 0]
