"""The NLP scaled by the system's inertia (`dmoc.scaling`): the factors follow the
inertia written out here, results come back in the system's units, and mixed inertia
scales converge.

Oracles, none taken from the code under test:
- the knife edge's mass matrix diag(m, m, J), force directions (cos, sin, 0), (0, 0, 1) and
  constraint row (-sin, cos, 0), written out below;
- the continuous optimum of the double integrator J theta'' = tau, rest to rest over
  Theta in T: tau(t) = 12 J Theta / T^2 (1/2 - t/T), cost 12 J^2 Theta^2 / T^3, reached at
  order 2 in h;
- the simulator replaying the optimal controls; the Hamiltonian form of the same system
  started at the Lagrangian optimum;
- the same problem built with every factor 1 (the NLP before the scaling), its KKT
  conditions evaluated with CasADi's AD at the result (tests from a review of the change).
"""

import json
import pathlib
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.optimal_control.nlp import transcription as transcription_module
from dmoc import diagnostics
from dmoc.optimal_control.nlp.scaling import inertia, power_of_two
from dmoc.systems import knife_edge, rolling_disk

MASS, YAW = 1024.0, 2.0        # powers of 2: the factors are these, not rounded ones


def parking(mass, yaw, *, steps=100, variant="+", goal=(0.0, 1.0, 0.0), system=None):
    disc = dmoc.discretize(system or knife_edge(mass=mass, inertia=yaw), 4.0 / steps)
    return dmoc.OptimalControlProblem(disc, steps, q_start=[0.0, 0.0, 0.3], q_goal=goal,
                                      variant=variant)


def blocks(problem, scale, layout):
    return {name: layout.unpack(scale, name) for name in layout.blocks if layout.numel(name)}


@pytest.mark.parametrize("variant", ["+", "-"])
def test_knife_edge_factors_follow_its_inertia(variant):
    """x_scale: p by (m, m, J), u0 (a force along the blade) by m, u1 (a torque) by J,
    lam and the end impulse by m (the constraint row acts on x and y only), the rest 1.
    g_scale: the momentum rows of every step and both ends by 1 / (m, m, J), the
    constraint row 1."""
    problem = parking(MASS, YAW, variant=variant)
    x = blocks(problem, problem.x_scale, problem.x_layout)
    g = blocks(problem, problem.g_scale, problem.g_layout)
    M = np.array([MASS, MASS, YAW])
    np.testing.assert_allclose(x["p"], M[:, None], rtol=1e-14)
    np.testing.assert_allclose(x["u"], np.array([[MASS], [YAW]]) * np.ones((1, 100)), rtol=1e-14)
    np.testing.assert_allclose(x["lam"], MASS, rtol=1e-14)
    impulse = "nu" if variant == "+" else "mu"
    np.testing.assert_allclose(x[impulse], MASS, rtol=1e-14)
    for name in ("q", "v_start", "v_goal"):
        np.testing.assert_array_equal(x[name], 1.0)
    rows = problem.dynamics_rows.slices()
    np.testing.assert_allclose(g["dynamics"][rows["left"]], 1 / M[:, None] * np.ones((1, 100)), rtol=1e-14)
    np.testing.assert_array_equal(g["dynamics"][rows["constraint"]], 1.0)
    for end in ("start", "goal"):
        np.testing.assert_allclose(g[end], 1 / M[:, None], rtol=1e-14)


def test_a_change_of_mass_unit_changes_the_scaled_nlp_only_by_the_cost_unit():
    """The same blade in two mass units 2^10 apart (m = 1024, J = 1 and m = 1, J = 2^-10):
    at a random point the scaled rows agree to 2e-16 and the objectives differ by the unit
    squared (the objective is not scaled); both optima are the same up to the units."""
    unit = 2.0 ** 10
    big, small = (parking(unit * m, unit * J, goal=(0.0, 1.0, 0.3)) for m, J in ((1.0, 2 ** -10), (1 / unit, 2 ** -20)))
    x = np.random.default_rng(3).uniform(-1, 1, big.x_layout.size)
    values = [ca.Function("fg", [P.nlp["x"], P.nlp["p"]], [P.nlp["f"], P.nlp["g"]])(x, P.p) for P in (big, small)]
    assert float(values[0][0]) == pytest.approx(unit ** 2 * float(values[1][0]), rel=1e-15)
    g0, g1 = (np.array(v[1]).ravel() for v in values)
    assert np.abs(g0 - g1).max() <= 1e-15 * np.abs(g0).max()
    a, b = dmoc.optimize(big), dmoc.optimize(small)
    assert a.cost == pytest.approx(unit ** 2 * b.cost, rel=1e-9)
    assert np.abs(a.trajectory.q - b.trajectory.q).max() <= 1e-8
    np.testing.assert_allclose(a.trajectory.u, unit * b.trajectory.u, rtol=0,
                               atol=1e-8 * np.abs(a.trajectory.u).max())


def test_factors_are_the_nearest_powers_of_two():
    """m = 1000, J = 3 (log2 9.97 and 1.58): momenta by 1024 and 4, rows by their inverses."""
    problem = parking(1000.0, 3.0)
    np.testing.assert_array_equal(problem.x_layout.unpack(problem.x_scale, "p")[:, 0], [1024.0, 1024.0, 4.0])
    np.testing.assert_array_equal(problem.g_layout.unpack(problem.g_scale, "start")[:, 0],
                                  [2.0 ** -10, 2.0 ** -10, 0.25])


def test_unit_inertia_leaves_the_nlp_unscaled():
    problem = dmoc.problems.knife_edge_parking(20)
    np.testing.assert_array_equal(problem.x_scale, 1.0)
    np.testing.assert_array_equal(problem.g_scale, 1.0)


@pytest.mark.parametrize("motion, length", [(0.0, 1.0), (1e-12, 1.0), (1e-9, 1.0),
                                            (1e-6, 2.0 ** -20), (1e-3, 2.0 ** -10)])
def test_a_motion_of_round_off_size_sets_no_length(motion, length):
    """Knife-edge parking (m = J = 1) by `motion` along x: below sqrt(machine epsilon),
    1.5e-8, of the rest length 1 the ends are the same point up to round-off and the
    lengths are the rest ones, l = 1 (unscaled, as goal = start); above it the motion's own,
    l = |motion| for every coordinate (equal inertias; the heading turns over 1 rad), to
    the nearest power of 2."""
    problem = dmoc.problems.knife_edge_parking(20, goal=(motion, 0.0, 0.0))
    np.testing.assert_array_equal(problem.x_layout.unpack(problem.x_scale, "q")[:, 0], length)


def test_degenerate_directions_take_the_geometric_mean_of_the_others():
    """L = 2 v0^2 + v2^2 / 2 + q1 v1 (linear in v1): inertia (4, 0, 1) -> (4, 2, 1);
    H = p0^2 / 6 + p1^2 / 24: inertia (3, 12); point vortices (L linear in v): no inertia
    anywhere -> all 1."""
    q = np.zeros(3)
    lagrangian = dmoc.MechanicalSystem(lambda q, v: 2 * v[0] ** 2 + v[2] ** 2 / 2 + q[1] * v[1], 3)
    np.testing.assert_allclose(inertia(lagrangian, q), [4.0, 2.0, 1.0], rtol=1e-14)
    hamiltonian = dmoc.HamiltonianSystem(lambda q, p: p[0] ** 2 / 6 + p[1] ** 2 / 24, 2)
    np.testing.assert_allclose(inertia(hamiltonian, q[:2]), [3.0, 12.0], rtol=1e-14)
    vortices = dmoc.systems.point_vortices([1.0, -0.5])
    np.testing.assert_array_equal(inertia(vortices, np.arange(1.0, 5.0)), np.ones(4))


@pytest.mark.parametrize("variant", ["+", "-"])
def test_turn_in_place_of_a_heavy_blade_gives_the_torque_in_its_units(variant):
    """m = 1e3, J = 1e-3 turning by Theta = 1.2 in T = 4: the torque at the step midpoints
    and the cost approach the continuous optimum at order 2 (N = 50, 100), the force stays
    0 (its acceleration below 1e-10 of the torque's), and p_theta is the discrete Legendre transform J v - h/2 tau (not
    that times a scale factor)."""
    J, Theta, T = 1e-3, 1.2, 4.0
    errors = []
    for N in (50, 100):
        problem = parking(1e3, J, steps=N, variant=variant, goal=(0.0, 0.0, 0.3 + Theta))
        result = dmoc.optimize(problem)
        traj = result.trajectory
        t_mid = (np.arange(N) + 0.5) * T / N
        tau = 12 * J * Theta / T ** 2 * (0.5 - t_mid / T)
        errors.append((np.abs(traj.u[:, 1] - tau).max() / np.abs(tau).max(),
                       abs(result.cost / (12 * J ** 2 * Theta ** 2 / T ** 3) - 1)))
        # the force drives the mass, the torque the yaw inertia: compare accelerations
        np.testing.assert_allclose(traj.u[:, 0] / 1e3, 0.0, atol=1e-10 * np.abs(tau).max() / J)
        v_theta, h = np.diff(traj.q[:, 2]) / (T / N), T / N    # p_k = J v_k+1/2 - h/2 tau_k
        np.testing.assert_allclose(traj.p[:-1, 2], J * v_theta - h / 2 * traj.u[:, 1],
                                   rtol=0, atol=1e-9 * J * np.abs(v_theta).max())
    orders = np.log2(np.array(errors[0]) / np.array(errors[1]))
    assert errors[1][0] < 1e-3 and errors[1][1] < 1e-3, errors
    assert np.all(orders > 1.7), (errors, orders)


@pytest.mark.parametrize("mass, yaw, resolved", [(1e3, 1.0, True), (1.0, 1e-3, False)])
def test_mixed_inertia_parking_converges_and_replays(mass, yaw, resolved):
    """Parallel parking with inertias 1e3 apart (before the scaling IPOPT stopped at 1000
    iterations on both): solved, and the simulator replays the optimum to 1e-8 of the size
    of q and p (the bound of the unit-inertia replay tests). The heavy blade's optimum is
    resolved by the grid (velocity jumps below 0.5). Which optimum the light rotor reaches
    depends on rounding (docs/verification.md, "Known shortfalls"): one that spins by about
    pi per step, which its verdict reports, or a resolved one (with MUMPS's pivot tolerance
    1e-6 the first, with dmoc's 1e-4 the second); never a spinning optimum passed."""
    problem = parking(mass, yaw, goal=(0.0, 1.0, 0.3))
    result = dmoc.optimize(problem, throw=False)
    jumps = diagnostics.velocity_jumps(result.trajectory).max()
    if resolved or result.success:
        assert result.success and jumps < 0.5
    else:
        assert result.status == "under_resolved" and result.stats["return_status"] == "Solve_Succeeded"
        assert jumps > 0.5
    replay_q, replay_p = diagnostics.replay_error(problem, result)
    assert replay_q <= 1e-8 * max(1.0, np.abs(result.trajectory.q).max())
    assert replay_p <= 1e-8 * np.abs(result.trajectory.p).max()


def test_warm_start_from_the_optimum_of_a_scaled_problem_is_already_optimal():
    """The multipliers come back in the system's units and go in scaled again: a re-solve
    from the optimum of the heavy blade takes no iteration."""
    problem = parking(MASS, YAW, goal=(0.0, 1.0, 0.3))
    result = dmoc.optimize(problem)
    again = dmoc.optimize(problem, guess=result)
    assert again.stats["warm_start"] and again.stats["iterations"] == 0
    assert abs(again.cost - result.cost) <= 1e-12 * result.cost


@pytest.mark.parametrize("variant", ["+", "-"])
def test_hamiltonian_form_of_a_mixed_inertia_blade_has_the_lagrangian_optimum(variant):
    """H = (px^2 + py^2) / (2m) + pth^2 / (2J) (m = 4, J = 1/4): momenta scaled by M, and
    only the rows in momentum units by 1/M ((+): "left"; (-): none imposed; the boundary
    rows dH/dp - v are velocities). Started at the Lagrangian optimum it keeps its cost
    to 1e-9 and its positions to 1e-7."""
    m, J = 4.0, 0.25
    system = dmoc.HamiltonianSystem(
        lambda q, p: (p[0] ** 2 + p[1] ** 2) / (2 * m) + p[2] ** 2 / (2 * J), 3,
        constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
        force=lambda q, p, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]), n_u=2)
    lagrangian = dmoc.optimize(parking(m, J, variant=variant))
    problem = parking(m, J, variant=variant, system=system)
    M, rows = np.array([m, m, J]), problem.dynamics_rows.slices()
    dynamics = problem.g_layout.unpack(problem.g_scale, "dynamics")
    p_scale = problem.x_layout.unpack(problem.x_scale, "p")        # p_0 ... p_N variables here
    np.testing.assert_allclose(p_scale, np.broadcast_to(M[:, None], p_scale.shape), rtol=1e-14)
    if variant == "+":      # left = p_k - D1 H_d+ (momentum), right = D2 H_d+ - q_{k+1}
        np.testing.assert_allclose(dynamics[rows["left"]], 1 / M[:, None] * np.ones((1, 100)), rtol=1e-14)
        for name in ("right", "stage", "constraint"):
            np.testing.assert_array_equal(dynamics[rows[name]], 1.0)
    else:                   # left = -q_k - D1 H_d-, the momentum row "right" substituted
        np.testing.assert_array_equal(dynamics, 1.0)
    for end in ("start", "goal"):      # dH/dp - v: velocities
        np.testing.assert_array_equal(problem.g_layout.unpack(problem.g_scale, end), 1.0)
    result = dmoc.optimize(problem, guess=lagrangian.trajectory)
    assert result.cost == pytest.approx(lagrangian.cost, rel=1e-9)
    assert np.abs(result.trajectory.q - lagrangian.trajectory.q).max() <= 1e-7


def trajectory_of(q, h):
    q = np.asarray(q, dtype=float).reshape(len(q), -1)
    N = len(q) - 1
    return dmoc.Trajectory(h * np.arange(N + 1), q, np.zeros_like(q), np.zeros((N, 0)),
                           np.zeros((N, 0)), h, "+")


def test_velocity_jumps_measure_how_the_grid_resolves_the_motion():
    """A sinusoid sin(omega t) on N = 1000 steps: 2 sin(omega h / 2) to 1e-5 relative; a
    uniform motion 0; a coordinate moving by rounding only 0; one that moves in a single
    step 1; one that reverses every step 2."""
    N, T = 1000, 3.0
    h, omega = T / N, 2 * np.pi / T
    t = h * np.arange(N + 1)
    still = 1e-17 * np.cos(7 * t)
    jump = np.where(t > T / 2, 1.0, 0.0)
    q = np.column_stack([np.sin(omega * t), 0.4 * t, still, jump, 0.1 * (-1.0) ** np.arange(N + 1)])
    ratios = dmoc.diagnostics.velocity_jumps(trajectory_of(q, h))
    assert ratios[0] == pytest.approx(2 * np.sin(omega * h / 2), rel=1e-5)
    np.testing.assert_allclose(ratios[1:], [0.0, 0.0, 1.0, 2.0], rtol=0, atol=1e-9)


# --- against the unscaled NLP --------------------------------------------------------------------

def unscaled(make, monkeypatch):
    """The problem `make()` builds, with every factor 1."""
    with monkeypatch.context() as m:
        m.setattr(transcription_module, "nlp_scales", lambda disc, formulation, layouts, *data:
                  tuple(np.ones(layout.size) for layout in layouts))
        return make()


def unscaled_values(problem, x, lam_g):
    """(d/dx (f + lam_g^T g), g) of the unscaled NLP at x, by CasADi's AD."""
    lg = ca.MX.sym("lg", problem.nlp["g"].shape[0])
    L = problem.nlp["f"] + ca.dot(lg, problem.nlp["g"])
    F = ca.Function("F", [problem.nlp["x"], problem.nlp["p"], lg],
                    [ca.gradient(L, problem.nlp["x"]), problem.nlp["g"]])
    return tuple(np.array(v).ravel() for v in F(x, problem.p, lam_g))


def light_parking(mass=1024.0, **kw):
    disc = dmoc.discretize(knife_edge(mass=mass, inertia=2.0), 0.2)
    return dmoc.OptimalControlProblem(disc, 20, q_start=[0, 0, 0.3], q_goal=[0, 1, 0.3], **kw)


def test_active_control_bound_holds_in_system_units_with_its_multiplier(monkeypatch):
    """A force bound 0.8 of the free optimum's peak, m = 16: attained to 1e-9, never
    exceeded, and x, lam_x, lam_g satisfy the unscaled NLP's stationarity."""
    free = dmoc.optimize(light_parking(16.0))
    bound = 0.8 * np.abs(free.trajectory.u[:, 0]).max()

    def make():
        return light_parking(16.0, control_bounds=([-bound, None], [bound, None]))
    problem, plain = make(), unscaled(make, monkeypatch)
    result = dmoc.optimize(problem)
    u0 = result.trajectory.u[:, 0]
    assert (problem.x_layout.unpack(problem.x_scale, "u")[0] == 16.0).all()
    assert bound * (1 - 1e-9) <= np.abs(u0).max() <= bound * (1 + 1e-12)
    assert np.abs(result.lam_x).max() > 0
    grad, _ = unscaled_values(plain, result.x, result.lam_g)
    np.testing.assert_allclose(grad + result.lam_x, 0.0, atol=1e-8 * np.abs(grad).max())


def test_max_violation_is_measured_in_system_units(monkeypatch):
    problem, plain = light_parking(), unscaled(light_parking, monkeypatch)
    result = dmoc.optimize(problem, options={"max_iter": 2}, throw=False)
    _, g = unscaled_values(plain, result.x, np.zeros(problem.g_layout.size))
    assert result.stats["max_violation"] == pytest.approx(np.abs(g).max(), rel=1e-9)


def minimum_time():
    disc = dmoc.discretize(knife_edge(mass=1024.0, inertia=2.0), 0.2)
    return dmoc.OptimalControlProblem(disc, 20, q_start=[0, 0, 0.3], q_goal=[0, 1, 0.3],
                                      duration=(2.0, 6.0),
                                      running_cost=lambda q, v, u: 1 + 1e-3 * ca.sumsqr(u))


RELAXED = {"bound_relax_factor": 1e-8}       # IPOPT's own default


def test_max_violation_is_that_of_the_returned_x_after_the_bounds_are_honored(monkeypatch):
    """Minimum time (T in [2, 6]) ends with h on a bound. With IPOPT's relaxed bounds,
    honor_original_bounds moves h onto it after IPOPT's last g: max_violation is |g| at the
    returned x (about 1e-11 of the momenta). With dmoc's default bound_relax_factor 0, h
    stays within its bounds and the rows hold to rounding."""
    problem, plain = minimum_time(), unscaled(minimum_time, monkeypatch)
    moved = dmoc.optimize(problem, options=RELAXED, check=False)
    assert problem.x_layout.unpack(moved.x, "h").item() in (2.0 / 20, 6.0 / 20)
    _, g = unscaled_values(plain, moved.x, np.zeros(problem.g_layout.size))
    assert moved.stats["max_violation"] == pytest.approx(np.abs(g).max(), rel=1e-9)
    assert moved.stats["max_violation"] > 1e-13 * np.abs(moved.trajectory.p).max()
    exact = dmoc.optimize(problem, check=False)
    h = problem.x_layout.unpack(exact.x, "h").item()
    assert 2.0 / 20 <= h <= 6.0 / 20 and min(abs(h - 0.1), abs(h - 0.3)) <= 1e-12
    assert exact.stats["max_violation"] <= 1e-12 * np.abs(exact.trajectory.p).max()


def test_an_active_state_bound_leaves_the_rows_exact(monkeypatch):
    """|x| <= 0.05 cuts the parking manoeuvre (active at the optimum): the rows of the
    unscaled NLP hold to 1e-13 at the returned x (with IPOPT's relaxed bounds: 4.9e-9)."""
    def make():
        disc = dmoc.discretize(knife_edge(), 0.04)
        return dmoc.OptimalControlProblem(disc, 100, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                          state_bounds=([-0.05, None, None], [0.05, None, None]))
    problem, plain = make(), unscaled(make, monkeypatch)
    result = dmoc.optimize(problem)
    assert np.abs(result.trajectory.q[:, 0]).max() == pytest.approx(0.05, rel=1e-9)
    _, g = unscaled_values(plain, result.x, np.zeros(problem.g_layout.size))
    assert np.abs(g).max() <= 1e-13 and result.stats["max_violation"] <= 1e-13


def test_cost_is_the_objective_at_the_returned_x():
    """With h moved onto its bound after IPOPT's last f (relaxed bounds, as above), the
    cost is sum_k h (1 + 1e-3 |u_k|^2) of the returned trajectory, by hand, to 1e-13
    (IPOPT's last f was 3e-10 off; second review of the change)."""
    result = dmoc.optimize(minimum_time(), options=RELAXED, check=False)
    h, u = result.trajectory.h, result.trajectory.u
    assert h in (0.1, 0.3)
    assert result.cost == pytest.approx(float(np.sum(h * (1 + 1e-3 * np.sum(u ** 2, axis=1)))), rel=1e-13)


@pytest.mark.parametrize("value", [1.5e308, np.finfo(float).max, 1e-310, 5e-324])
def test_factors_stay_normal_powers_of_two_at_the_extremes(value):
    """Scaling by s is exact only for a normal s: the factor of an absurd inertia is
    clipped to 2^1023 or 2^-1022, never inf or subnormal."""
    s = float(power_of_two(value))
    assert np.isfinite(s) and s >= np.finfo(float).tiny and s == 2.0 ** round(np.log2(s))
    assert (1.1 * s) / s == 1.1 and (1.1 / s) * s == 1.1


def test_lobatto4_factors_by_node_and_degree_of_freedom():
    M = np.array([1024.0, 1024.0, 2.0])
    disc = dmoc.discretize(knife_edge(mass=1024.0, inertia=2.0), 0.2, "lobatto4")
    problem = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0.3], q_goal=[0, 1, 0.3])
    u = problem.x_layout.unpack(problem.x_scale, "u")[:, 0]
    np.testing.assert_array_equal(u, np.tile([1024.0, 2.0], 4))           # node by node
    rows = problem.dynamics_rows.slices()
    dynamics = problem.g_layout.unpack(problem.g_scale, "dynamics")[:, 0]
    np.testing.assert_array_equal(dynamics[rows["stage"]], np.tile(1 / M, 2))   # stage by stage


def test_lobatto3_multiplier_factors_by_node():
    """Rolling disk A(q) = [[1, 0, -R cos phi, 0], [0, 1, -R sin phi, 0]], inertias
    (m, m, I, J), moving by (1, 1, free, 0): d^2 = 2 m, lengths d / sqrt(M_i) but for the
    heading, which turns the rows by their own size over |a_r o l| / |da_r/dphi o l|; each
    multiplier's factor fits c |a_ri| to the momentum scales M_i l_i (least squares in
    relative terms), the same at both nodes, to the nearest power of 2."""
    m, I, J, R, phi = 5.0, 0.3, 0.1, 1.0, 0.4
    disc = dmoc.discretize(rolling_disk(mass=m, radius=R, roll_inertia=I, steer_inertia=J), 0.2, "lobatto3")
    problem = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0, phi], q_goal=[1, 1, None, phi])
    M = np.array([m, m, I, J])
    l = np.sqrt(2 * m / M)
    rows = np.array([[1, 0, -R * np.cos(phi), 0], [0, 1, -R * np.sin(phi), 0]])
    turns = np.array([[0, 0, R * np.sin(phi), 0], [0, 0, -R * np.cos(phi), 0]])
    l[3] = min(l[3], min(np.linalg.norm(a * l) / np.linalg.norm(t * l) for a, t in zip(rows, turns)))
    a = np.abs(rows) / (M * l)
    fit = a.sum(axis=1) / (a ** 2).sum(axis=1)
    np.testing.assert_array_equal(problem.x_layout.unpack(problem.x_scale, "lam")[:, 0],
                                  np.tile(power_of_two(fit), 2))


def test_hamiltonian_minus_with_momenta_variables_scales_its_right_rows():
    """No constraint: each coordinate's length is the motion's, d / sqrt(M_i) with d^2 =
    m * 1^2 (the goal 1 along y), and the momentum rows are divided by M_i l_i."""
    m, J = 4.0, 0.25
    system = dmoc.HamiltonianSystem(lambda q, p: (p[0] ** 2 + p[1] ** 2) / (2 * m) + p[2] ** 2 / (2 * J), 3,
                                    force=lambda q, p, u: u, n_u=3)
    problem = dmoc.OptimalControlProblem(dmoc.discretize(system, 0.1), 5, q_start=[0, 0, 0],
                                         q_goal=[0, 1, 0], variant="-", momenta="variables")
    rows = problem.dynamics_rows.slices()
    M = np.array([m, m, J])
    np.testing.assert_array_equal(problem.g_layout.unpack(problem.g_scale, "dynamics")[rows["right"], 0],
                                  1 / (M * np.sqrt(m / M)))


def disk(phi):
    disc = dmoc.discretize(rolling_disk(mass=5.0, radius=1.0, roll_inertia=0.5), 0.1)
    return dmoc.OptimalControlProblem(disc, 30, q_start=[0, 0, 0, phi], q_goal=[1, 1, None, phi + 1.0])


def test_problems_differing_in_their_factors_only_do_not_share_term_functions():
    """Headings 0 and 1.4 give other multiplier factors (2 and 4) and nothing else: the
    second problem, solved after the first in this process, equals it solved alone."""
    first, second = disk(0.0), disk(1.4)
    assert not np.array_equal(first.x_scale, second.x_scale)
    dmoc.optimize(first)
    here = dmoc.optimize(second)
    script = ("import json; from tests.optimize.test_scaling import disk; import dmoc\n"
              "print(json.dumps(dmoc.optimize(disk(1.4)).trajectory.lam.tolist()))")
    root = pathlib.Path(__file__).parents[2]
    alone = json.loads(subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                                      check=True, cwd=root).stdout)
    np.testing.assert_allclose(here.trajectory.lam, alone, rtol=1e-8, atol=1e-10)


def test_an_infinite_force_direction_at_q_ref_does_not_poison_the_factors():
    """r free at both ends puts q_ref at r = 0, where dF/du = (1, 1/r) is infinite; the
    state bounds keep the NLP away from it (this solved before the scaling)."""
    system = dmoc.MechanicalSystem(lambda q, v: 1.5 * (v[0] ** 2 + q[0] ** 2 * v[1] ** 2), 2,
                                   force=lambda q, v, u: ca.vertcat(u[0], u[1] / q[0]), n_u=2)
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(system, 0.1), 20, q_start=[None, 0], q_goal=[None, 1.0],
        state_bounds=([0.5, None], [2, None]), running_cost=lambda q, v, u: ca.sumsqr(u) + (q[0] - 1) ** 2)
    assert np.isfinite(problem.x_scale).all() and np.isfinite(problem.g_scale).all()
    assert dmoc.optimize(problem).success



def test_a_problems_mechanical_data_are_evaluated_once_at_its_q_ref(monkeypatch):
    """The scales, the lengths and the default guess of one problem read M, dF/du, A and
    dA/dq at its q_ref: evaluated once (the rolling disk, N = 4), kept read-only, and the
    same numbers as an evaluation of their own."""
    from dmoc.optimal_control.nlp import scaling
    dmoc.clear_caches()
    evaluate, made = scaling._evaluated, []
    monkeypatch.setattr(scaling, "_evaluated", lambda *a: made.append(a) or evaluate(*a))
    problem = dmoc.problems.rolling_disk_steering(4)
    dmoc.optimal_control.solve(problem, options={"print_level": 0, "max_iter": 1}, throw=False)
    assert len(made) == 1
    q_ref = np.asarray(problem.transcription.q_ref, dtype=float)
    values = scaling._mechanical_data(problem.disc.system, q_ref)
    assert len(made) == 1 and not any(a.flags.writeable for a in values)
    assert all(np.array_equal(a, b) for a, b in zip(values, evaluate(problem.disc.system, q_ref)))
