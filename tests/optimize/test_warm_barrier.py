"""Warm starts stay warm with active bounds (issue 40): `WARM_START_OPTIONS` starts the
barrier small and keeps the optimum's bounds and multipliers where they are, so a re-solve
from the own optimum takes a few iterations and a neighbouring goal few more; cold starts
keep IPOPT's defaults. Iteration counts are deterministic for one build."""

import numpy as np
import pytest

import dmoc
import dmoc.problems as P
from dmoc.optimal_control.solver.ipopt import COLD_START_OPTIONS, WARM_START_OPTIONS

from .hard_problems import bounded_disk

# IPOPT's own barrier start and warm-start pushes: the warm options before issue 40
BEFORE = {"mu_init": 0.1, "warm_start_bound_push": 1e-3, "warm_start_bound_frac": 1e-3,
          "warm_start_slack_bound_push": 1e-3, "warm_start_slack_bound_frac": 1e-3,
          "warm_start_mult_bound_push": 1e-3}


def knife_bounds():
    """Knife-edge parking, N = 50, |u| <= 0.7 of the unbounded optimum's largest: bounds
    active on arcs of the optimum."""
    free = P.knife_edge_parking(50)
    bound = 0.7 * np.abs(dmoc.optimize(free).trajectory.u).max()
    return dmoc.OptimalControlProblem(free.disc, 50, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                      control_bounds=([-bound] * 2, [bound] * 2))


def test_cold_start_keeps_ipopt_defaults():
    assert not set(COLD_START_OPTIONS) & set(BEFORE)
    assert WARM_START_OPTIONS["mu_init"] < BEFORE["mu_init"]


@pytest.mark.parametrize("make", [knife_bounds, lambda: bounded_disk(40)], ids=["knife-bounds", "disk-free-time"])
def test_resolve_from_own_optimum(make):
    problem = make()
    cold = dmoc.optimize(problem)
    assert cold.stats["iterations"] >= 15
    warm = dmoc.optimize(problem, guess=cold)
    assert warm.stats["warm_start"] and warm.stats["iterations"] <= 3
    assert abs(warm.cost - cold.cost) <= 1e-10 * abs(cold.cost)
    before = dmoc.optimize(problem, guess=cold, options=BEFORE)
    assert before.stats["iterations"] > 2 * warm.stats["iterations"]


def test_neighbouring_goal_of_a_free_time_problem():
    problem = bounded_disk(40)
    cold = dmoc.optimize(problem)
    moved = problem.with_boundary(q_goal=[1.1, 0.9, None, np.pi / 2])
    warm = dmoc.optimize(moved, guess=cold)
    fresh = dmoc.optimize(moved)
    assert warm.stats["iterations"] <= 10 < fresh.stats["iterations"]
    assert abs(warm.cost - fresh.cost) <= 1e-9 * fresh.cost
    assert abs(warm.trajectory.t[-1] - fresh.trajectory.t[-1]) <= 1e-7


def test_mpc_steps_on_a_bounded_problem():
    """The knife edge's closed loop (examples/mpc_knife_edge.py's plant, 10 % heavier)
    with |u| bounded: the warm steps take a median of at most 15 iterations."""
    problem = knife_bounds().with_steps(30)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1, inertia=1.0), problem.disc.h)
    controller = dmoc.MPC(problem)
    q, p = np.zeros(3), np.zeros(3)
    for _ in range(10):
        u = controller.step(q, p=p)
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
    iterations = [record.iterations for record in controller.log[1:]]
    assert all(record.success for record in controller.log)
    assert np.median(iterations) <= 15
