"""A step found by continuation in h (`dmoc.simulation.continuation`): where Newton's
method from the previous step's root finds no root of a large step, the root followed
from a small step is the physical one.

Oracle, not taken from dmoc's code: the bicycle car's continuous equations written out in
tests/results/verdict_study.py (`car_plant`, `vector_field`: M q'' + A^T mu = f and A q'' =
-(dA/dt) q' from its Lagrangian), integrated by scipy's DOP853 over the step under the same
control functions. A root of the step equations on another branch lies O(1) of the motion
away from it; the physical root within the rule's own error of one step (lobatto4, order 6:
7.8e-5 of the motion at h = 1 s, where Newton needs no continuation).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from tests.results.verdict_study import car_plant, vector_field

CAR = (1500.0, 2000.0, 1.0, 2.7, 0.3)      # m, I_z, I_delta, wheelbase, centre of mass ahead


def force(s):
    """The drive force (N) and steering torque (N m) at the fraction s of the step."""
    return np.array([6000.0 * (1 - s) + 500.0 * s, 0.1 * np.cos(np.pi * s)])


def first_step(h, rule="lobatto4"):
    """`simulate`'s step of h seconds of the car from rest at the origin under `force`
    (its values at the rule's control nodes), and DOP853's end configuration."""
    disc = dmoc.discretize(dmoc.systems.car(*CAR), h, rule)
    controls = np.concatenate([force(s) for s in disc.rule.control_nodes])[None]
    run = dmoc.simulate(disc, q0=np.zeros(4), v0=np.zeros(4), steps=1, controls=controls,
                        throw=False, jit=False)
    field = vector_field(car_plant(*CAR))
    exact = solve_ivp(lambda t, x: np.asarray(field(x, force(t / h))).ravel(), (0.0, h), np.zeros(8),
                      method="DOP853", rtol=1e-12, atol=1e-12).y[:4, -1]
    return run, exact


@pytest.mark.parametrize("h, error", [(1.0, 1e-4), (2.0, 1e-3), (3.0, 3e-3)])
def test_a_step_newton_cannot_take_is_continued_to_the_physical_root(h, error):
    """At h = 1 s Newton takes the step from rest; at 2 and 3 s (the car moves 5.5 and
    12 m, turns by 0.11 and 0.56 rad) it finds no root from rest and the continuation
    does: within the rule's error of the continuous motion (measured 7.8e-5, 2.7e-4 and
    1.2e-3 of its largest coordinate)."""
    run, exact = first_step(h)
    assert run.success and run.stats["continued_steps"] == ([] if h == 1.0 else [0])
    assert np.abs(run.trajectory.q[-1] - exact).max() <= error * np.abs(exact).max()


def test_a_step_without_a_physical_root_still_fails():
    """At h = 4 s (15 m and 1.8 rad in one step) the branch from small steps does not reach
    the full step: the step fails as it did without continuation, and says so."""
    run, _ = first_step(4.0)
    assert not run.success and run.status == "newton_failed"
    assert run.stats["completed_steps"] == 0 and run.stats["continued_steps"] == []
    assert "Newton did not converge at step 0" in run.message
