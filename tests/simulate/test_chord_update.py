"""The chord updates of the simulator's fast path (dmoc.simulation.chord_update): a step of
more than four unknowns with a dense Jacobian and no multipliers is solved with the
Jacobian factorized once, and gives the solution of the step equations solved by scipy."""

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import root

import dmoc
from dmoc.principle.residual import step_residual
from dmoc.simulation.chord_update import CHORD_UPDATE_TOL, chord_delta, chord_factors, remaining_error
from dmoc.simulation.stepper import DiracStepper

N, H, KAPPA = 5, 0.1, 0.7


def _coupled_pendulums():
    """L = |v|^2/2 - V(q), V = -sum_i cos q_i - KAPPA sum_{i<j} cos(q_i - q_j): n = 5, the
    step's Jacobian -I/h - h/4 V''(q) is dense and depends on q."""
    def lagrangian(q, v):
        pairs = sum(ca.cos(q[i] - q[j]) for i in range(N) for j in range(i + 1, N))
        return 0.5 * ca.dot(v, v) + ca.sum1(ca.cos(q)) + KAPPA * pairs
    return dmoc.MechanicalSystem(lagrangian, N, force=lambda q, v, u: u, n_u=N)


def _gradient_V(q):
    difference = q[:, None] - q[None, :]
    return np.sin(q) + KAPPA * np.sin(difference).sum(axis=1)


def _by_hand(q0, p0, controls, h=H):
    """(+) midpoint steps solved with scipy's root (oracle): with v = (q1 - q0)/h and
    qm = q0 + h v/2, p0 - v - h/2 V'(qm) + h/2 u = 0, then p1 = v - h/2 V'(qm) + h/2 u."""
    q, p = [np.asarray(q0, float)], [np.asarray(p0, float)]
    for u in controls:
        def left(v):
            return p[-1] - v - h / 2 * _gradient_V(q[-1] + h * v / 2) + h / 2 * u
        v = root(left, p[-1], tol=1e-15).x
        q.append(q[-1] + h * v)
        p.append(v - h / 2 * _gradient_V(q[-2] + h * v / 2) + h / 2 * u)
    return np.array(q), np.array(p)


def test_dense_step_takes_the_chord_and_a_small_one_newton():
    disc = dmoc.discretize(_coupled_pendulums(), H)
    assert DiracStepper(step_residual(disc), 1e-12, 50).chord
    knife = dmoc.discretize(dmoc.systems.knife_edge(), H)     # 4 unknowns, a multiplier
    assert not DiracStepper(step_residual(knife), 1e-12, 50).chord


@pytest.mark.parametrize("jit", [False, True])
@pytest.mark.parametrize("h", [H, 0.3])
def test_chord_steps_solve_the_step_equations(jit, h):
    """At h = 0.1 most steps take 3 or 4 updates, at h = 0.3 up to all 8 (fewer leave 26 and
    6 steps unconverged): the updates beyond the first two are taken while needed, and
    stop at round-off (a loose stop leaves 1e-11 in q after 30 steps)."""
    controls = np.tile(np.linspace(-0.5, 0.5, N), (30, 1))
    q0, v0 = np.linspace(-1.0, 1.0, N), np.linspace(1.5, -0.5, N)
    res = dmoc.simulate(dmoc.discretize(_coupled_pendulums(), h), q0=q0, v0=v0, steps=30,
                        controls=controls, jit=jit)
    assert res.success and res.stats["robust_steps"] == 0       # every step by the chord
    q, p = _by_hand(q0, v0, controls, h)
    assert np.abs(res.trajectory.q - q).max() < 1e-13
    assert np.abs(res.trajectory.p - p).max() < 1e-12


def test_a_kick_the_chord_does_not_converge_is_redone_by_newton():
    h, controls = 0.5, np.zeros((10, N))
    controls[5] = 8.0 * np.linspace(-1.0, 1.0, N)     # the warm start is far off, J(q) too
    q0, v0 = np.zeros(N), np.linspace(1.0, -1.0, N)
    res = dmoc.simulate(dmoc.discretize(_coupled_pendulums(), h), q0=q0, v0=v0, steps=10,
                        controls=controls, jit=False)
    assert res.success and res.stats["robust_steps"] > 0
    traj = res.trajectory       # each step against the oracle's from the same state
    for k in range(10):
        q, p = _by_hand(traj.q[k], traj.p[k], controls[k:k + 1], h)
        assert np.abs(traj.q[k + 1] - q[1]).max() < 1e-12
        assert np.abs(traj.p[k + 1] - p[1]).max() < 1e-12


def test_a_vanishing_leading_pivot_is_redone_by_newton():
    """Pendulum 0 inverted (its unstable rate lambda, lambda^2 = -V''_00) and h = 2/lambda:
    the step's leading pivot J_00 = -1/h - h/4 V''_00 at the warm start (at rest, dq = 0)
    is zero, elimination without pivoting divides by it and the fast step turns
    non-finite, while J is nonsingular through the coupling -h/4 V''_0j. The line-search
    Newton redoes such steps: the trajectory is scipy's."""
    q0, v0 = np.array([np.pi - 0.3, 0.2, -0.1, 0.3, 0.0]), np.zeros(N)
    V00 = np.cos(q0[0]) + KAPPA * np.cos(q0[0] - q0[1:]).sum()      # d^2V/dq_0^2 < 0
    h = 2 / np.sqrt(-V00)
    assert abs(-1 / h - h / 4 * V00) <= 1e-15 / h
    disc = dmoc.discretize(_coupled_pendulums(), h)
    stepper = DiracStepper(step_residual(disc), 1e-12, 50)
    _, out = stepper.fast(np.concatenate([q0, v0, np.zeros(N)]), np.zeros(N), h)
    assert float(out[stepper.out.slice("nonfinite").start]) > 0       # the chord's step 0
    res = dmoc.simulate(disc, q0=q0, v0=v0, steps=6, jit=False)
    assert res.success
    q, p = _by_hand(q0, v0, np.zeros((6, N)), h)
    assert np.abs(res.trajectory.q - q).max() < 1e-12
    assert np.abs(res.trajectory.p - p).max() < 1e-12


def test_chord_factors_solve_like_numpy():
    """J = (I + L) U without pivoting and its substitutions give numpy's J^{-1} g for a
    step-like J: a definite mass matrix over -h, a skew part and a small symmetric one."""
    rng = np.random.default_rng(4)
    B, C, S = (rng.normal(size=(6, 6)) for _ in range(3))
    J = -(B @ B.T + 0.1 * np.eye(6)) / 0.01 + (C - C.T) + 0.01 * (S + S.T)
    g = rng.normal(size=6)
    Js, gs = ca.SX.sym("J", 6, 6), ca.SX.sym("g", 6)
    solve = ca.Function("solve", [Js, gs], [chord_delta(*chord_factors(Js), gs)])
    x = np.array(solve(J, g)).ravel()
    assert np.abs(x - np.linalg.solve(J, g)).max() < 1e-15 * np.abs(x).max() * np.linalg.cond(J)


def test_remaining_error_is_the_geometric_tail():
    def value(last, before):
        return float(remaining_error(ca.DM(last), ca.DM(before)))
    assert value(1e-9, 1e-7) == pytest.approx(1e-9 * 0.01 / 0.99, rel=1e-6)   # rate 0.01
    assert value(1e-6, 1e-7) == 1e-6                   # diverging (or stalled): the update
    assert value(1e-10, 2e-10) > CHORD_UPDATE_TOL      # rate 1/2: 1e-10 left
    cycle = 2.546994955081901e-18                      # arm6 at rest: two points at round-off
    assert value(cycle, cycle * (1 + 2e-16)) == cycle   # a stall, not a tail of 1e16 updates


def test_a_chord_step_stalled_at_round_off_is_accepted_by_its_residual():
    stepper = DiracStepper(step_residual(dmoc.discretize(_coupled_pendulums(), H)), 1e-12, 50)
    out = np.zeros((3, stepper.out.size))
    at = {name: stepper.out.slice(name).start for name in ("rnorm", "update", "scale")}
    out[:, at["scale"]] = 10.0
    out[:, at["update"]] = [1e-13, 1e-11, 1e-11]          # its tail, or a stalled update
    out[:, at["rnorm"]] = [1e-9, 1e-12, 1e-9]             # rows relative 1e-10, 1e-13, 1e-10
    assert stepper.accepted(out).tolist() == [True, True, False]
