"""Degenerate Lagrangians (docs/degenerate.md): the LC circuit and point vortices, built in.

Oracles, none taken from the code under test:
- the closed forms `lc_circuit_solution`, `point_vortices_solution` against DOP853 on the
  continuous equations written here by hand (the circuit's Kirchhoff equations, the
  Biot-Savart law);
- the normalization of the vortex Hamiltonian: the Euler-Lagrange vector field of the
  system's own L, solved here from its CasADi derivatives, against Biot-Savart;
- the LC energy and Kirchhoff's laws written by hand on the computed charges;
- DMOC: the continuous minimum-energy control of the reduced circuit
  L_0 q_L'' = u - q_L/C from its controllability Gramian (Van Loan's matrix exponential);
- the refusal of the trapezoid: the step equations written out (docs/degenerate.md).
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import dmoc
from dmoc.diagnostics import replay_error
from dmoc.discrete import QuadratureRule
from dmoc.systems import lc_circuit, lc_circuit_solution, point_vortices, point_vortices_solution

L0, C1, C2 = 0.8, 0.5, 1.5
C = C1 + C2
LC_Q0 = np.array([0.1, C1 * 0.4, C2 * 0.4])          # capacitor voltage 0.4
LC_V0 = np.array([0.3, C1 / C * 0.3, C2 / C * 0.3])   # inductor current 0.3
VORTEX_Q0 = np.array([1.0, 0.0, -0.5, 0.3])
VORTEX_CASES = {"co-rotating": (1.0, 2.0), "counter-rotating": (-1.5, 0.5),
                "opposite": (1.0, -1.0)}
VARIANTS = ["+", "-"]


def loglog_slope(steps, errors):
    return np.polyfit(np.log(1.0 / np.asarray(steps)), np.log(errors), 1)[0]


def biot_savart(q, gamma):
    """rdot_i = sum_j Gamma_j/(2 pi) J (r_i - r_j)/|r_i - r_j|^2, J = rotation by +90 deg."""
    r = q.reshape(-1, 2)
    v = np.zeros_like(r)
    for i in range(len(gamma)):
        for j in range(len(gamma)):
            if i != j:
                dx, dy = r[i] - r[j]
                v[i] += gamma[j] / (2 * np.pi) * np.array([-dy, dx]) / (dx**2 + dy**2)
    return v.ravel()


def dop853(rhs, z0, times):
    sol = solve_ivp(lambda t, z: rhs(z), (times[0], times[-1]), z0, method="DOP853",
                    t_eval=times, rtol=1e-12, atol=1e-12)
    assert sol.success, sol.message
    return sol.y.T


# ---------------------------------------------------------------------------------------
# The closed forms and the vortex normalization


def test_lc_solution_solves_kirchhoff_equations():
    """z = (q_L, q_1, q_2, i): q_L' = i, L_0 i' = -V with V = q_1/C_1 the voltage of both
    capacitors, q_j' = C_j i/C (Kirchhoff's current law with equal voltages)."""
    times = np.linspace(0.0, 6.0, 13)
    z = dop853(lambda z: [z[3], C1 / C * z[3], C2 / C * z[3], -z[1] / C1 / L0],
               np.r_[LC_Q0, LC_V0[0]], times)
    q, v = lc_circuit_solution(times, LC_Q0, LC_V0, inductance=L0, capacitances=(C1, C2))
    np.testing.assert_allclose(q, z[:, :3], rtol=0, atol=1e-10)
    np.testing.assert_allclose(v[:, 0], z[:, 3], rtol=0, atol=1e-10)
    np.testing.assert_allclose(v[:, 0], v[:, 1] + v[:, 2], rtol=0, atol=1e-15)


@pytest.mark.parametrize("case", VORTEX_CASES)
def test_vortex_pair_solution_solves_biot_savart(case):
    gamma = VORTEX_CASES[case]
    times = np.linspace(0.0, 8.0, 17)
    z = dop853(lambda z: biot_savart(z, gamma), VORTEX_Q0, times)
    q, v = point_vortices_solution(times, VORTEX_Q0, gamma)
    np.testing.assert_allclose(q, z, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v, [biot_savart(x, gamma) for x in q], rtol=0, atol=1e-12)


def test_vortex_lagrangian_gives_biot_savart():
    """L = alpha(q).v - H(q): the Euler-Lagrange rows d/dt alpha - dL/dq = M v + c are
    linear in v; v = -M^{-1} c must be the Biot-Savart velocity, which fixes the sign and
    the factor 1/(4 pi) of H (counter-clockwise for positive circulation)."""
    gamma = (1.0, -0.7, 2.3)
    system = point_vortices(gamma)
    q, v = ca.SX.sym("q", 6), ca.SX.sym("v", 6)
    L = system.lagrangian(q, v)
    rows = ca.jacobian(ca.gradient(L, v), q) @ v - ca.gradient(L, q)
    M, c = ca.jacobian(rows, v), ca.substitute(rows, v, ca.SX.zeros(6))
    field = ca.Function("field", [q], [-ca.solve(M, c)])
    rng = np.random.default_rng(3)
    for x in rng.normal(size=(5, 6)):
        np.testing.assert_allclose(np.array(field(x)).ravel(), biot_savart(x, gamma),
                                   rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------------------------------
# Simulation: order 2 and structure at round-off


@pytest.mark.parametrize("variant", VARIANTS)
def test_lc_circuit_order_two(variant):
    steps, T, errors = [100, 200, 400, 800], 10.0, []
    for N in steps:
        traj = dmoc.simulate(dmoc.discretize(lc_circuit(L0, (C1, C2)), T / N, "midpoint"),
                             q0=LC_Q0, v0=LC_V0, steps=N, variant=variant).trajectory
        exact, _ = lc_circuit_solution(traj.t, LC_Q0, LC_V0, inductance=L0, capacitances=(C1, C2))
        errors.append(np.abs(traj.q - exact).max())
    assert errors[-1] > 1e-8                                  # above round-off, not exact
    assert abs(loglog_slope(steps, errors) - 2.0) < 0.35, errors


@pytest.mark.parametrize("variant", VARIANTS)
def test_lc_circuit_kirchhoff_and_energy_over_1e4_steps(variant):
    """Kirchhoff's current law at every node (q_L - q_1 - q_2 constant), the voltage law
    where the midpoint rule samples the capacitors (q_{k+1/2} = (q_k + q_{k+1})/2), and
    the energy L_0/2 v_L^2 + q_1^2/(2 C_1) + q_2^2/(2 C_2) at the same points, written by
    hand: for this linear circuit the midpoint scheme conserves it exactly."""
    h = 0.01
    traj = dmoc.simulate(dmoc.discretize(lc_circuit(L0, (C1, C2)), h), q0=LC_Q0, v0=LC_V0,
                         steps=10_000, variant=variant).trajectory
    q = traj.q
    assert np.abs(q[:, 0] - q[:, 1] - q[:, 2] - (LC_Q0[0] - LC_Q0[1] - LC_Q0[2])).max() < 1e-14
    mid, current = (q[1:] + q[:-1]) / 2, (q[1:, 0] - q[:-1, 0]) / h
    assert np.abs(mid[:, 1] / C1 - mid[:, 2] / C2).max() < 1e-13
    E = L0 / 2 * current**2 + mid[:, 1] ** 2 / (2 * C1) + mid[:, 2] ** 2 / (2 * C2)
    assert np.abs(E - E[0]).max() < 1e-13 * E[0]
    assert np.ptp(q[:, 1]) > 0.3                           # it oscillates


def vortex_run(gamma, steps, h, variant):
    disc = dmoc.discretize(point_vortices(gamma), h, "midpoint")
    return dmoc.simulate(disc, q0=VORTEX_Q0, v0=np.zeros(4), steps=steps, variant=variant).trajectory


@pytest.mark.parametrize("case", ["co-rotating", "counter-rotating"])
@pytest.mark.parametrize("variant", VARIANTS)
def test_vortex_pair_order_two(case, variant):
    """Against the rigid rotation at Omega = (Gamma_1 + Gamma_2)/(2 pi d^2) over T = 8."""
    gamma, steps, errors = VORTEX_CASES[case], [50, 100, 200, 400], []
    for N in steps:
        traj = vortex_run(gamma, N, 8.0 / N, variant)
        exact, _ = point_vortices_solution(traj.t, VORTEX_Q0, gamma)
        errors.append(np.abs(traj.q - exact).max())
    assert errors[-1] > 1e-8
    assert abs(loglog_slope(steps, errors) - 2.0) < 0.35, errors


@pytest.mark.parametrize("variant", VARIANTS)
def test_opposite_vortex_pair_is_exact(variant):
    """Gamma_1 = -Gamma_2: the pair translates uniformly, which the midpoint rule
    reproduces exactly (the midpoint of a straight segment is on it)."""
    gamma = VORTEX_CASES["opposite"]
    traj = vortex_run(gamma, 100, 0.08, variant)
    exact, _ = point_vortices_solution(traj.t, VORTEX_Q0, gamma)
    assert np.abs(traj.q - exact).max() < 1e-13


@pytest.mark.parametrize("case", VORTEX_CASES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_vortex_pair_invariants_over_1e4_steps(case, variant):
    """Distance and centre of vorticity (the linear impulse Gamma_1 r_1 + Gamma_2 r_2 for an
    opposite pair) are conserved to round-off of the positions, 1e-13 max |q| (the
    opposite pair travels 50 units); the co- and counter-rotating pairs turn many times."""
    gamma = VORTEX_CASES[case]
    q = vortex_run(gamma, 10_000, 0.05, variant).q
    r1, r2 = q[:, :2], q[:, 2:]
    distance = np.hypot(*(r1 - r2).T)
    impulse = gamma[0] * r1 + gamma[1] * r2
    floor = 1e-13 * np.abs(q).max()
    assert np.abs(distance - distance[0]).max() < floor
    assert np.abs(impulse - impulse[0]).max() < floor
    assert np.ptp(q) > 1.0


# ---------------------------------------------------------------------------------------
# DMOC: steering the charge with the voltage source


def minimum_energy(T, goal):
    """Cost and control of the continuous minimum-energy transfer of x = (q_L, i) from 0 to
    `goal` under x' = A x + B u, A = [[0, 1], [-1/(L_0 C), 0]], B = (0, 1/L_0): W(T) =
    int_0^T e^{As} B B^T e^{A^T s} ds from Van Loan's exponential, cost goal^T W^{-1} goal,
    u*(t) = B^T e^{A^T (T - t)} W^{-1} goal."""
    A, B = np.array([[0.0, 1.0], [-1 / (L0 * C), 0.0]]), np.array([[0.0], [1 / L0]])
    E = expm(np.block([[-A, B @ B.T], [np.zeros((2, 2)), A.T]]) * T)
    W = E[2:, 2:].T @ E[:2, 2:]
    w = np.linalg.solve(W, goal)
    return float(goal @ w), lambda t: np.array([(B.T @ expm(A.T * (T - s)) @ w)[0] for s in t])


@pytest.mark.parametrize("variant", VARIANTS)
def test_dmoc_voltage_source_matches_gramian_minimum_energy(variant):
    """Rest to rest, q_L from 0 to Q in T (each capacitor ends with its share C_j Q/C):
    the discrete optimum converges to the Gramian optimum at order 2, in cost and in the
    control at the step midpoints, and the simulator replays it."""
    T, Q, steps = 3.0, 1.0, [10, 20, 40, 80]
    cost, control = minimum_energy(T, np.array([Q, 0.0]))
    cost_errors, control_errors = [], []
    for N in steps:
        problem = dmoc.OptimalControlProblem(
            dmoc.discretize(lc_circuit(L0, (C1, C2)), T / N), N, q_start=[0, 0, 0],
            q_goal=[Q, C1 / C * Q, C2 / C * Q], variant=variant)
        result = dmoc.optimize(problem)
        t_mid = (result.trajectory.t[:-1] + result.trajectory.t[1:]) / 2
        cost_errors.append(abs(result.cost - cost))
        control_errors.append(np.abs(result.trajectory.u[:, 0] - control(t_mid)).max())
        assert max(replay_error(problem, result)) < 1e-8
    assert abs(loglog_slope(steps, cost_errors) - 2.0) < 0.35, cost_errors
    assert abs(loglog_slope(steps, control_errors) - 2.0) < 0.35, control_errors


# ---------------------------------------------------------------------------------------
# Rules without a one-step map are refused by the principle, so by both consumers


def test_trapezoid_refused_on_lc_circuit():
    """Trapezoid: L_d = h/2 [L(q_k, v) + L(q_{k+1}, v)], so the left rows (37) of q_1 and
    q_2 read -h/2 q_{j,k}/C_j + lam = 0 with p_j = 0: no q_{k+1} in them, two rows for the
    single unknown lam. The message names the rule, the coordinates and the midpoint. The
    step residual refuses it (the one-step-map test belongs to the principle stage)."""
    system = lc_circuit(L0, (C1, C2))
    with pytest.raises(ValueError, match=r"`rule` 'trapezoid'") as info:
        dmoc.step_residual(dmoc.discretize(system, 0.1, "trapezoid"))
    message = str(info.value)
    assert "('q_1', 'q_2')" in message and "'q_L'" not in message
    assert "rule='midpoint'" in message
    with pytest.raises(ValueError, match=r"\('q_1', 'q_2'\)"):
        dmoc.step_residual(dmoc.Discretization(system, 0.1, dmoc.Trapezoid()), "-")
    # An interior node does not help while the end-point rows still lack q_{k+1}.
    simpson = QuadratureRule("lobatto3", 4, (0.0, 0.5, 1.0), ((0.0, 1 / 6), (0.5, 2 / 3), (1.0, 1 / 6)))
    with pytest.raises(ValueError, match=r"`rule` 'lobatto3'.*\('q_1', 'q_2'\)"):
        dmoc.step_residual(dmoc.discretize(system, 0.1, simpson))


@pytest.mark.parametrize("consumer", ["simulate", "OptimalControlProblem"])
def test_trapezoid_refused_before_either_consumer(consumer):
    """Both consumers take the Discretization, so they fail alike with the same message
    instead of a structural-rank error inside CasADi (simulate) or a solve (optimize)."""
    run = {"simulate": lambda d: dmoc.simulate(d, q0=LC_Q0, v0=LC_V0, steps=5),
           "OptimalControlProblem": lambda d: dmoc.OptimalControlProblem(
               d, 10, q_start=[0, 0, 0], q_goal=[1, C1 / C, C2 / C])}[consumer]
    with pytest.raises(ValueError, match=r"`rule` 'trapezoid'.*\('q_1', 'q_2'\).*rule='midpoint'"):
        run(dmoc.discretize(lc_circuit(L0, (C1, C2)), 0.1, "trapezoid"))


def test_midpoint_refused_when_a_coordinate_enters_nothing():
    """A coordinate absent from L, A and f is undetermined by every rule; the hint then
    points at the system, not at another rule."""
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2 - 0.5 * q[0] ** 2, 2,
                                   names=("x", "idle"))
    with pytest.raises(ValueError, match=r"`rule` 'midpoint'.*\('idle',\).*must enter L") as info:
        dmoc.step_residual(dmoc.discretize(system, 0.1))
    assert "rule='midpoint'" not in str(info.value)


@pytest.mark.parametrize("system", [point_vortices((1.0, 2.0)), dmoc.systems.knife_edge(incline=0.3)],
                         ids=["point_vortices", "knife_edge"])
def test_trapezoid_accepted_where_the_step_is_determined(system):
    """Linear in v, the vortices' trapezoid rows involve q_{k+1} through alpha(q_{k+1});
    the knife edge is regular. Neither is refused."""
    disc = dmoc.discretize(system, 0.1, "trapezoid")
    assert disc.rule == dmoc.Trapezoid()
    assert dmoc.step_residual(disc).rule == dmoc.Trapezoid()


@pytest.mark.parametrize("call, name", [
    (lambda: lc_circuit(L0, (C1,)), "capacitances"),
    (lambda: lc_circuit(-1.0), "inductance"),
    (lambda: lc_circuit_solution(1.0, [0, 1, 1], LC_V0, capacitances=(C1, C2)), "q0"),
    (lambda: lc_circuit_solution(1.0, LC_Q0, [1, 0, 0], capacitances=(C1, C2)), "v0"),
    (lambda: point_vortices([1.0, 0.0]), "circulations"),
    (lambda: point_vortices_solution(1.0, np.zeros(6), (1, 1, 1)), "circulations"),
    (lambda: point_vortices_solution(1.0, [1, 1, 1, 1], (1, 1)), "q0"),
])
def test_constructors_and_solutions_name_bad_arguments(call, name):
    with pytest.raises(ValueError, match=f"`{name}`"):
        call()
