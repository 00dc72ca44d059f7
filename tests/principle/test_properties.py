"""Property-based tests (hypothesis) over random initial conditions, parameters and step
sizes for every built-in system: omega_d = 0, Dirac membership, bounded energy error, the
save/load round trip, and the replay of optima.

Oracles, none taken from the code under test: allowed start velocities are built by hand
from each system's constraints (blade direction, rolling without slipping, tangent to the
sphere, the currents of the LC circuit's Kirchhoff law); the energy error of a
second-order variational integrator is O(h^2) and bounded (no drift), checked against
E_0 with the step size the example drew; the round trip must be bit for bit; the replay
is the other consumer of the same residual.
"""

from dataclasses import fields

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

import dmoc
from dmoc import diagnostics, systems

SETTINGS = settings(max_examples=10, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
unit = st.floats(-1.0, 1.0)
angle = st.floats(-np.pi, np.pi)
positive = st.floats(0.5, 2.0)
step = st.floats(0.005, 0.05)


def knife_edge_case(draw):
    theta, speed, turn = draw(angle), draw(unit), draw(unit)
    system = systems.knife_edge(mass=draw(positive), inertia=draw(positive),
                                incline=draw(st.floats(0.0, 0.5)))
    return system, [draw(unit), draw(unit), theta], [speed * np.cos(theta), speed * np.sin(theta), turn]


def rolling_disk_case(draw):
    radius, phi, roll, steer = draw(positive), draw(angle), draw(unit), draw(unit)
    system = systems.rolling_disk(mass=draw(positive), radius=radius)
    return (system, [draw(unit), draw(unit), draw(angle), phi],
            [radius * np.cos(phi) * roll, radius * np.sin(phi) * roll, roll, steer])


def spherical_pendulum_case(draw):
    length, polar, azimuth = draw(positive), draw(st.floats(0.3, 2.8)), draw(angle)
    q = length * np.array([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth),
                           -np.cos(polar)])
    spin = np.array([draw(unit), draw(unit), draw(unit)])
    return systems.spherical_pendulum(mass=draw(positive), length=length), q, np.cross(spin, q)


def point_vortices_case(draw):
    gammas = [draw(positive), -draw(positive)]
    q = [draw(unit), draw(unit), 2.0 + draw(unit), draw(unit)]     # never coincident
    return systems.point_vortices(gammas), q, np.zeros(4)


def lc_circuit_case(draw):
    c1, c2, volts, current = draw(positive), draw(positive), draw(unit), draw(unit)
    system = systems.lc_circuit(inductance=draw(positive), capacitances=(c1, c2))
    c = c1 + c2
    return system, [draw(unit), c1 * volts, c2 * volts], [current, c1 / c * current, c2 / c * current]


CASES = {"knife_edge": knife_edge_case, "rolling_disk": rolling_disk_case,
         "spherical_pendulum": spherical_pendulum_case, "point_vortices": point_vortices_case,
         "lc_circuit": lc_circuit_case}


@st.composite
def runs(draw, name):
    system, q0, v0 = CASES[name](draw)
    disc = dmoc.discretize(system, draw(step))
    variant = draw(st.sampled_from(["+", "-"]))
    return disc, dmoc.simulate(disc, q0=q0, v0=v0, steps=40, variant=variant).trajectory


@pytest.mark.parametrize("name", CASES)
def test_structure_holds_for_random_data(name, tmp_path):
    @SETTINGS
    @given(runs(name))
    def check(run):
        disc, traj = run
        scale = 1.0 + np.abs(traj.q).max() + np.abs(traj.p).max()
        assert diagnostics.constraint_violation(disc, traj).max(initial=0.0) <= 1e-12 * scale
        if disc.rule.name in ("midpoint", "trapezoid"):
            assert dmoc.dirac.dirac_defect(disc, traj).max() <= 1e-11 * scale
        assert diagnostics.residual_norms(disc, traj).max() <= 1e-10 * scale
        E = diagnostics.energy(disc, traj)
        assert np.abs(E - E[0]).max() <= 10.0 * disc.h ** 2 * (1.0 + abs(E[0])) * scale
        path = tmp_path / "run.npz"
        traj.save(path)
        back = dmoc.Trajectory.load(path)
        for f in fields(traj):
            assert np.array_equal(getattr(back, f.name), getattr(traj, f.name)), f.name

    check()


@SETTINGS
@given(goal=st.tuples(unit, unit, angle), h=st.floats(0.05, 0.3), variant=st.sampled_from("+-"),
       rule=st.sampled_from(["midpoint", "trapezoid"]))
@example(goal=(0.0, 3.7792981112032195e-114, 0.0), h=0.05, variant="+", rule="midpoint")
@example(goal=(0.0, 0.0, -3.7792981112032195e-114), h=0.05, variant="+", rule="midpoint")
def test_optima_replay_for_random_goals(goal, h, variant, rule):
    disc = dmoc.discretize(systems.knife_edge(), h, rule)
    problem = dmoc.OptimalControlProblem(disc, 12, q_start=[0, 0, 0], q_goal=list(goal),
                                         variant=variant)
    result = dmoc.optimize(problem)
    scale = 1.0 + np.abs(result.trajectory.p).max()
    assert max(diagnostics.replay_error(problem, result)) <= 1e-8 * scale
    np.testing.assert_allclose(result.trajectory.q[-1], goal, rtol=0, atol=1e-8)
