"""The verdict's kept Functions (issue 25): what `judge` reuses from one re-solve to the next
gives the verdict bit for bit as built afresh.

Oracles, none taken from the cache under test:
- the end velocities of the interpolant by a Function built for the one call, as
  `end_velocities` did before it kept one per rule (the old path, written out here);
- the Verdict of each status (passed, under_resolved, path_violated, not_replayable) from
  a process state with every cache emptied, against the same call with the caches warm
  and after other structures have been judged in between.
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.problems import knife_edge_parking, rolling_disk_steering
from dmoc.results.knot_velocities import end_velocities
from dmoc.drivers.verdict import judge


def end_velocities_built_per_call(disc, traj):
    """The old path: the Function of the interpolant's end velocities built for this call."""
    n, rule = disc.system.n, disc.rule
    q0, q1, s, h = (ca.SX.sym(name, size) for name, size in
                    (("q0", n), ("q1", n), ("s", traj.s.shape[1]), ("h", 1)))
    ends = rule.interpolant.samples(q0, q1, rule.stage_configurations(s, n), h,
                                    ((0.0, 1.0), (1.0, 1.0)))
    velocities = ca.Function("end_velocities", [q0, q1, s, h], [ends[0][2], ends[1][2]])
    start, end = velocities.map(traj.steps)(traj.q[:-1].T, traj.q[1:].T, traj.s.T, traj.h)
    return np.array(start).T, np.array(end).T


def hamiltonian_knife():
    return dmoc.HamiltonianSystem(lambda q, p: ca.dot(p, p) / 2 + 0.3 * q[0], 3,
                                  constraints=lambda q: ca.horzcat(ca.sin(q[2]), -ca.cos(q[2]), 0))


@pytest.mark.parametrize("make", [
    lambda: dmoc.discretize(dmoc.systems.knife_edge(), 0.1, "midpoint"),
    lambda: dmoc.discretize(dmoc.systems.knife_edge(), 0.1, "trapezoid"),
    lambda: dmoc.discretize(dmoc.systems.knife_edge(), 0.1, "lobatto3"),    # n, stage rows as the next
    lambda: dmoc.discretize(dmoc.systems.rolling_disk(), 0.07, "lobatto4"),
    lambda: dmoc.discrete_legendre(dmoc.discretize(dmoc.systems.knife_edge(), 0.1, "midpoint")),
    lambda: dmoc.discretize(hamiltonian_knife(), 0.1, "symplectic-euler")],
    ids=["midpoint", "trapezoid", "lobatto3", "lobatto4", "legendre-midpoint", "symplectic-euler"])
def test_the_kept_end_velocities_equal_those_built_per_call_bit_for_bit(make):
    disc = make()
    q0 = np.linspace(0.1, 0.4, disc.system.n)
    for steps in (7, 3, 7):           # a new N and the first N again: the kept Function serves both
        controls = np.random.default_rng(steps).normal(size=(steps, disc.n_controls))
        traj = dmoc.simulate(disc, q0=q0, p0=np.zeros(disc.system.n), steps=steps,
                             controls=controls, jit=False).trajectory
        for kept, fresh in zip(end_velocities(disc, traj), end_velocities_built_per_call(disc, traj)):
            assert kept.shape == fresh.shape == (steps, disc.system.n)
            assert kept.tobytes() == fresh.tobytes()


def problems():
    """One problem per status of the verdict."""
    limit = 0.3
    rate_disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / 50, "lobatto3")
    car_disc = dmoc.discretize(dmoc.systems.car(mass=1500.0), 3.0 / 60)
    return {"passed": rolling_disk_steering(11, rule="lobatto4"),
            "under_resolved": knife_edge_parking(10),
            "path_violated": dmoc.OptimalControlProblem(
                rate_disc, 50, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                path_constraints=lambda q, v, u: ca.vertcat(v[2] - limit, -v[2] - limit)),
            "not_replayable": dmoc.OptimalControlProblem(car_disc, 60, q_start=[0.0] * 4,
                                                         q_goal=[40.0, 3.5, 0.0, 0.0])}


def test_a_verdict_with_warm_caches_equals_the_first_bit_for_bit():
    """(The rate-limited parking is judged with the optimum of the parking without the
    limit, whose knots cross it: its own optimum holds the limit at every knot.)"""
    solved = {"path_violated": knife_edge_parking(50, rule="lobatto3")}
    optima = {status: (problem, dmoc.optimize(solved.get(status, problem), check=False))
              for status, problem in problems().items()}
    first = {}
    for status, (problem, result) in optima.items():
        dmoc.clear_caches()
        first[status] = judge(problem, result)
        assert first[status].status == status
    for _ in range(2):      # warm, the other structures judged in between
        for status, (problem, result) in optima.items():
            again = judge(problem, result)
            for name, value in first[status].as_dict().items():
                assert type(getattr(again, name)) is type(value)
                assert repr(getattr(again, name)) == repr(value), name
                if isinstance(value, float):
                    assert np.float64(getattr(again, name)).tobytes() == np.float64(value).tobytes()
