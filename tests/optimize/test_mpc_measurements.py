"""dmoc.MPC on a plant it does not model, measured with noise: the measurement policy.

Oracles, none from the controller: closed forms written here for the closest start in the
mass-matrix metric (a particle with masses m1, m2 on the line q0 + q1 = 1 or with the
velocity constraint v0 + v1 = 0; the unit sphere, clipped by a bound); the constraints
themselves, evaluated here (the knife edge's -sin(theta) v_x + cos(theta) v_y = 0 on
p = M v, the sphere's |q| = 1 and q . p = 0); a plant 20 % heavier than the model,
simulated by `dmoc.simulate` from its own state (never the measurement), whose states say
whether the loop reached the goal.
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc._util.deferred import replace
from dmoc.drivers import mpc
from dmoc.optimal_control import solve

LOWER, UPPER = np.array([-1.0, -0.05, -1.0]), np.array([1.0, 1.0, 1.0])
GOAL = np.array([0.0, 1.0, 0.0])          # on the upper bound of y


def bounded_parking(h=0.4, steps=10):
    """The knife edge (m = J = 1) parked 1 m sideways in a 4 s horizon within a box whose
    upper y bound is the goal's y, the heading and x bounds active on the way, the controls
    bounded by 5."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), h)
    return dmoc.OptimalControlProblem(disc, steps, q_start=[0, 0, 0], q_goal=GOAL,
                                      state_bounds=(LOWER, UPPER), control_bounds=([-5, -5], [5, 5]))


def closed_loop(controller, plant, q, p, steps, measure):
    """Run `steps` controller steps on `plant` (a Discretization) from (q, p); `measure`
    (q, p) -> the keywords of `controller.step`. Returns the plant's states (steps + 1, n)."""
    states = [q]
    for _ in range(steps):
        u = controller.step(**measure(q, p))
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        states.append(q)
    return np.array(states)


def test_200_noisy_steps_on_a_heavier_plant_reach_the_goal_within_the_box():
    """Gaussian noise (2 mm / 2 mrad on q, 5e-3 on v: every v off A(q) v = 0, and near the
    goal and the active bounds many q outside the box), a plant 20 % heavier (m = J =
    1.2): all 200 steps return controls, each records its status and what the policy did,
    every start used lies in the box with its velocity allowed, and from step 100 on the
    plant stays in the goal region |y - 1| <= 5 mm, |x| <= 0.15 m, |theta| <= 0.15 rad
    (the knife edge corrects a sideways error only by moving along and turning)."""
    problem = bounded_parking()
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.2, inertia=1.2), problem.disc.h)
    rng = np.random.default_rng(42)
    controller = dmoc.MPC(problem, on_failure="shift")

    def measure(q, p):
        return {"q": q + 2e-3 * rng.normal(size=3), "v": p / 1.2 + 5e-3 * rng.normal(size=3)}
    states = closed_loop(controller, plant, np.zeros(3), np.zeros(3), 200, measure)
    log = controller.log
    assert len(log) == 200 and all(r.measurement == "project" for r in log)
    assert all(r.success or r.plan_age > 0 for r in log)
    assert all(r.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level") or not r.success for r in log)
    outside = [r for r in log if ((r.q_measured < LOWER) | (r.q_measured > UPPER)).any()]
    assert len(outside) > 20 and all("state_bounds" in r.corrected for r in outside)
    assert all("velocity" in r.corrected and r.v_correction > 0 for r in log)
    for r in log:
        assert ((LOWER <= r.q) & (r.q <= UPPER)).all()
        np.testing.assert_array_equal(r.q, np.clip(r.q_measured, LOWER, UPPER))
        assert r.q_correction == pytest.approx(np.linalg.norm(r.q - r.q_measured), rel=1e-12)
        c, s = np.cos(r.q[2]), np.sin(r.q[2])
        assert abs(-s * r.p[0] + c * r.p[1]) <= 1e-12         # p = M v, m = 1: A(q) v = 0
        assert r.h == problem.disc.h
    error = np.abs(states[100:] - GOAL).max(axis=0)
    assert error[1] <= 5e-3 and error[0] <= 0.15 and error[2] <= 0.15, error


def sphere_problem():
    """A bead on the unit sphere (the spherical pendulum without gravity) moved a quarter
    turn about z in 1 s, y bounded above by its goal value and z below -0.5."""
    s, c = np.sin(0.5), np.cos(0.5)
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(gravity=0.0), 0.1)
    return dmoc.OptimalControlProblem(
        disc, 10, q_start=[s, 0, -c], q_goal=[0, s, None], state_bounds=([None, -0.05, None], [None, s, -0.5]),
        running_cost=lambda q, v, u: u[0] ** 2 + u[1] ** 2 + 100 * (q[0] ** 2 + (q[1] - s) ** 2))


def test_a_holonomic_plant_measured_off_the_sphere_reaches_the_goal():
    """Noise puts every measured q off |q| = 1 and v off the tangent plane; the starts
    used are on the sphere and tangent to it (to round-off), and a plant 20 % heavier
    settles at the goal to the sensor's accuracy: its last 10 states within 5 mm (2.5
    standard deviations of the noise on q) of it."""
    problem = sphere_problem()
    plant = dmoc.discretize(dmoc.systems.spherical_pendulum(mass=1.2, gravity=0.0), 0.1)
    rng = np.random.default_rng(0)
    controller = dmoc.MPC(problem)

    def measure(q, p):
        return {"q": q + 2e-3 * rng.normal(size=3), "v": p / 1.2 + 5e-3 * rng.normal(size=3)}
    states = closed_loop(controller, plant, problem.q_start, np.zeros(3), 60, measure)
    log = controller.log
    assert all(r.success and {"holonomic", "velocity"} <= set(r.corrected) for r in log)
    assert any("state_bounds" in r.corrected for r in log)
    for r in log:
        assert abs(np.linalg.norm(r.q) - 1) <= 1e-14 and abs(r.q @ r.p) <= 1e-14
    s, c = np.sin(0.5), np.cos(0.5)
    assert np.abs(states[-10:] - [0, s, -c]).max() <= 5e-3


def particle(m1, m2, **constraint):
    """A particle in the plane with masses m1, m2 along its axes, pushed by (u0, u1),
    with one constraint (`constraints` or `holonomic`), and a 4-step problem on it."""
    system = dmoc.MechanicalSystem(lambda q, v: (m1 * v[0] ** 2 + m2 * v[1] ** 2) / 2, 2,
                                   force=lambda q, v, u: u, n_u=2, **constraint)
    return dmoc.OptimalControlProblem(dmoc.discretize(system, 0.25), 4, q_start=[0.5, 0.5],
                                      q_goal=[0.6, None], state_bounds=([None, None], [0.75, None]))


def test_a_velocity_is_projected_in_the_metric_of_the_mass_matrix():
    """v0 + v1 = 0 with m1 = 1, m2 = 3: the allowed velocity closest to v in kinetic
    energy is t (1, -1) with t = (m1 v0 - m2 v1) / (m1 + m2) (the Euclidean projection
    would take (v0 - v1) / 2), its momentum (m1 t, -m2 t)."""
    problem = particle(1.0, 3.0, constraints=lambda q: ca.horzcat(1, 1))
    controller = dmoc.MPC(problem)
    controller.step([0.5, -0.5], v=[1.0, 0.5])
    record, t = controller.log[0], (1.0 * 1.0 - 3.0 * 0.5) / 4
    np.testing.assert_allclose(record.p, [t, -3 * t], rtol=1e-15, atol=1e-16)
    assert record.corrected == ("velocity",) and record.q_correction == 0
    assert record.v_correction == pytest.approx(np.hypot(1.0 - t, 0.5 + t), rel=1e-14)
    np.testing.assert_array_equal(record.v_measured, [1.0, 0.5])
    assert record.p_measured is None


def test_a_configuration_is_projected_onto_g_and_the_box_in_the_mass_metric():
    """q0 + q1 = 1 with m1 = 1, m2 = 3, q0 <= 0.75: from (0.7, 0.5) the closest point in
    the metric M is q_m - lam (1/m1, 1/m2), lam = 0.2 / (1/m1 + 1/m2) = 0.15: (0.55,
    0.45). From (0.9, 0.5), outside the box, it is (0.6, 0.4) (lam = 0.3), inside it: the
    measured q0 is not clipped first. From (1.2, 0), min (q0 - 1.2)^2 + 3 (1 - q0)^2 on the
    line is at q0 = 1.05, outside; with the bound active, (0.75, 0.25)."""
    problem = particle(1.0, 3.0, holonomic=lambda q: q[0] + q[1] - 1)
    controller = dmoc.MPC(problem)
    for measured, closest, corrected in (([0.7, 0.5], [0.55, 0.45], ("holonomic",)),
                                         ([0.9, 0.5], [0.6, 0.4], ("state_bounds", "holonomic")),
                                         ([1.2, 0.0], [0.75, 0.25], ("state_bounds", "holonomic"))):
        controller.step(measured, p=[0.0, 0.0])
        record = controller.log[-1]
        np.testing.assert_allclose(record.q, closest, rtol=0, atol=1e-15)
        assert record.corrected == corrected
        assert record.q_correction == pytest.approx(np.linalg.norm(np.subtract(closest, measured)), rel=1e-12)


def test_a_point_off_the_sphere_moves_radially_unless_a_bound_holds_an_entry():
    """The unit sphere (M = m I): (0, 1.1 sin 0.3, -1.1 cos 0.3) goes to q / |q|; (0.6, 0,
    -0.9) with x <= 0.5 keeps x = 0.5 and puts (y, z) on the circle of radius sqrt(0.75),
    along its own direction: (0.5, 0, -sqrt(0.75))."""
    disc = dmoc.discretize(dmoc.systems.spherical_pendulum(), 0.1)
    problem = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, -1], q_goal=[0.1, 0.1, None],
                                         state_bounds=([None] * 3, [0.5, None, None]))
    controller = dmoc.MPC(problem)
    q = 1.1 * np.array([0.0, np.sin(0.3), -np.cos(0.3)])
    controller.step(q, p=[0.0, 0.0, 0.0])
    np.testing.assert_allclose(controller.log[0].q, q / 1.1, rtol=0, atol=1e-15)
    controller.step([0.6, 0.0, -0.9], p=[0.0, 0.0, 0.0])
    np.testing.assert_allclose(controller.log[1].q, [0.5, 0.0, -np.sqrt(0.75)], rtol=0, atol=1e-15)


def test_measurement_refuse_names_the_step_the_value_and_the_bound():
    controller = dmoc.MPC(bounded_parking(), measurement="refuse")
    controller.step([0.0, 0.0, 0.0], v=[0.0, 0.0, 0.0])
    with pytest.raises(dmoc.InputError, match=r"MPC step 1: .*state_bounds: q\[1\] \(y\) = 1.002 > its "
                                              r"upper bound 1\b.*measurement='project'"):
        controller.step([0.0, 1.002, 0.0], v=[0.0, 0.0, 0.0])
    with pytest.raises(dmoc.InputError, match=r"MPC step 1: .*velocity: max abs\(A\(q\) v\) = 1.000e-01"):
        controller.step([0.0, 0.5, 0.0], v=[0.0, 0.1, 0.0])
    sphere = dmoc.MPC(sphere_problem(), measurement="refuse")
    with pytest.raises(dmoc.InputError, match=r"MPC step 0: .*holonomic: g\(q\)\[0\] = 2.100e-01"):
        sphere.step([0.0, 0.0, -1.1], p=[0.0, 0.0, 0.0])
    assert len(controller.log) == 1 and sphere.log == []
    with pytest.raises(dmoc.InputError, match=r"`measurement` must be one of 'project', 'refuse'; got 'clip'"):
        dmoc.MPC(bounded_parking(), measurement="clip")


def test_nan_and_wrong_shapes_name_the_step_and_the_entry():
    controller = dmoc.MPC(bounded_parking())
    controller.step([0.0, 0.0, 0.0], p=[0.0, 0.0, 0.0])
    with pytest.raises(dmoc.InputError, match=r"MPC step 1: `q` must be finite; entry \(1,\) is nan"):
        controller.step([0.0, np.nan, 0.0], p=[0.0, 0.0, 0.0])
    with pytest.raises(dmoc.InputError, match=r"MPC step 1: `v` must have shape \(3,\) for this system; got \(2,\)"):
        controller.step([0.0, 0.0, 0.0], v=[0.0, 0.0])
    with pytest.raises(dmoc.InputError, match=r"MPC step 1: `p` must be finite; entry \(2,\) is inf"):
        controller.step([0.0, 0.0, 0.0], p=[0.0, 0.0, np.inf])
    assert len(controller.log) == 1


def test_a_start_inside_an_obstacle_names_the_step():
    """Path constraints are no part of the projection: a measured q inside an obstacle is
    refused, the message naming the step."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.2)
    problem = dmoc.OptimalControlProblem(
        disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0],
        path_constraints=lambda q, v, u: 0.01 - ca.sumsqr(q[:2] - ca.DM([0.0, 0.5])))
    with pytest.raises(dmoc.InputError, match=r"MPC step 0: `q_start` must satisfy `path_constraints`"):
        dmoc.MPC(problem).step([0.0, 0.5, 0.0], p=[0.0, 0.0, 0.0])


def test_ctrl_c_propagates_with_on_failure_shift(monkeypatch):
    """A solve that reports "interrupted" (as `solve` does after a Ctrl-C) raises
    Interrupted from the step even when a plan is there to shift, and is recorded."""
    solves = []

    def interrupted_second(problem, **keywords):
        result = solve(problem, **keywords)
        solves.append(1)
        return result if len(solves) == 1 else replace(result, success=False, status="interrupted",
                                                       message="IPOPT: interrupted (Ctrl-C).")
    monkeypatch.setattr(mpc, "solve", interrupted_second)
    controller = dmoc.MPC(bounded_parking(), on_failure="shift")
    controller.step([0.0, 0.0, 0.0], p=[0.0, 0.0, 0.0])
    with pytest.raises(dmoc.Interrupted, match="MPC step 1: IPOPT: interrupted"):
        controller.step([0.0, 0.0, 0.0], p=[0.0, 0.0, 0.0])
    assert [r.plan_age for r in controller.log] == [0, None]


def test_a_configuration_the_box_leaves_no_room_for_names_the_step():
    """q0 + q1 = 1 in the box [0.8, 0.9] x [0.15, 0.2]: from (2, 0) the closest point on
    the line, (1.5, -0.5), leaves the box in both entries; both held at (0.9, 0.15), g =
    0.05 and no entry is free to move: refused, naming the step (the documented limit of
    holding the bounds the unbounded projection crosses, far from the box)."""
    system = dmoc.MechanicalSystem(lambda q, v: (v[0] ** 2 + v[1] ** 2) / 2, 2, n_u=2,
                                   force=lambda q, v, u: u, holonomic=lambda q: q[0] + q[1] - 1)
    problem = dmoc.OptimalControlProblem(dmoc.discretize(system, 0.25), 4, q_start=[0.85, 0.15],
                                         q_goal=[0.8, None], state_bounds=([0.8, 0.15], [0.9, 0.2]))
    controller = dmoc.MPC(problem)
    with pytest.raises(dmoc.InputError, match=r"MPC step 0: the measured q = \[2.0, 0.0\] cannot be put on "
                                              r"g\(q\) = 0 with the entries `state_bounds` leaves free"):
        controller.step([2.0, 0.0], p=[0.0, 0.0])
    assert controller.log == []


def test_a_hamiltonian_sphere_takes_p_and_refuses_v():
    """H = |p|^2 / 2 on |q| = 1 (no Lagrangian, the identity metric): q off the sphere
    goes to q / |q| with the measured p kept; a measured v is refused, naming `p`."""
    system = dmoc.HamiltonianSystem(lambda q, p: ca.dot(p, p) / 2, 3, holonomic=lambda q: ca.dot(q, q) - 1,
                                    force=lambda q, p, u: ca.vertcat(u[0], u[1], 0), n_u=2)
    problem = dmoc.OptimalControlProblem(dmoc.discretize(system, 0.1), 5, q_start=[0, 0, -1],
                                         q_goal=[0.1, 0.1, None])
    controller = dmoc.MPC(problem)
    with pytest.raises(dmoc.InputError, match=r"MPC step 0: give the measured momentum `p` for a HamiltonianSystem"):
        controller.step([0.0, 0.0, -1.0], v=[0.0, 0.0, 0.0])
    q = np.array([0.03, 0.04, -1.01])
    controller.step(q, p=[0.01, 0.0, 0.0])
    record = controller.log[0]
    np.testing.assert_allclose(record.q, q / np.linalg.norm(q), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(record.p, [0.01, 0.0, 0.0])
    assert record.corrected == ("holonomic",) and record.v_measured is None and record.v_correction == 0
