"""When the chord's updates stop (dmoc.simulation.chord_update.more_updates), on a robot whose
updates reach their round-off floor above CHORD_STOP_TOL: `arm6` swinging from q = 0.1 under
gravity and its joints' friction, h = 0.01. The trajectory equals the midpoint rule's solved
step by step by scipy's root on Pinocchio's M(q), C(q, v) and G(q), and no step takes all 8
updates, where the stop at the geometric tail alone took all 8 on 10 of the 60 steps."""

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import root

import dmoc
from dmoc.mechanics.robots import example_urdf
from dmoc.principle.residual import step_residual
from dmoc.simulation import chord_update, fast_path
from dmoc.simulation.stepper import DiracStepper
from tests.mechanics.test_robots import pinocchio_model, symmetric

pin = pytest.importorskip("pinocchio")
H, STEPS = 0.01, 60


def _by_hand(model, data, friction, q0, steps):
    """(q, p) of `steps` midpoint steps from q0 at rest (oracle): L_d = h L(q_m, v), v = (q1
    - q0)/h, q_m = q0 + h v/2, forces f = -D v at q_m (h/2 f on each end); dL/dq = C(q_m,
    v)^T v - G(q_m) (Pinocchio's C, with dM/dt = C + C^T), so that p0 - M(q_m) v + h/2
    (C^T v - G - D v) = 0 is solved for v by scipy's root and p1 = M(q_m) v + h/2 (C^T v -
    G - D v)."""
    def terms(q, v):
        M = symmetric(pin.crba(model, data, q))
        C = pin.computeCoriolisMatrix(model, data, q, v)
        G = pin.computeGeneralizedGravity(model, data, q)
        return M @ v, H / 2 * (C.T @ v - G - friction * v)

    q, p, v = [np.asarray(q0, float)], [np.zeros(len(q0))], np.zeros(len(q0))
    for _ in range(steps):
        def left(v):
            momentum, half = terms(q[-1] + H * v / 2, v)
            return p[-1] - momentum + half
        v = root(left, v, tol=1e-15).x
        momentum, half = terms(q[-1] + H * v / 2, v)
        q.append(q[-1] + H * v)
        p.append(momentum + half)
    return np.array(q), np.array(p)


@pytest.fixture(scope="module")
def arm():
    pytest.importorskip("adam.casadi")
    path = example_urdf("arm6")
    return dmoc.RobotSystem(path), pinocchio_model(path)


def test_the_stop_keeps_the_steps_solved_to_round_off(arm):
    """60 steps within 1e-13 of the oracle's (measured 1.4e-14 in q, 1.0e-14 in p, |p| up to
    11): stopping at an error left of 1e-15 instead ends 7.9e-13, 1.3e-12 away."""
    system, (model, data) = arm
    q0 = np.full(system.n, 0.1)
    res = dmoc.simulate(dmoc.discretize(system, H), q0=q0, v0=np.zeros(system.n), steps=STEPS, jit=False)
    assert res.success and res.stats["robust_steps"] == 0       # every step by the chord
    q, p = _by_hand(model, data, np.asarray(system.friction, float), q0, STEPS)
    assert np.abs(res.trajectory.q - q).max() < 1e-13
    assert np.abs(res.trajectory.p - p).max() < 1e-13


def _eighth_updates(residual, stepper, monkeypatch):
    """The steps of `stepper`'s run (from q = 0.1 at rest) whose fast step took an 8th update:
    its next state differs from that of the fast step built with CHORD_ITERATIONS = 7."""
    with monkeypatch.context() as patch:
        patch.setattr(fast_path, "CHORD_ITERATIONS", 7)
        capped = DiracStepper(residual, 1e-12, 50).fast
    n = residual.n
    start = np.concatenate([np.full(n, 0.1), np.zeros(stepper.state.size - n)])
    u = np.zeros((STEPS, n))
    states, *_ = stepper.run(start, u, H)
    full, seven = (np.array(f.map(STEPS)(states[:-1].T, u.T, H)[0]) for f in (stepper.fast, capped))
    return int((full != seven).any(axis=0).sum())


def test_steps_at_the_round_off_floor_stop_before_the_eighth_update(arm, monkeypatch):
    """Over these 60 steps no update is needed beyond the 7th: a step whose updates reach
    their floor (0.01-1 eps relative here, above CHORD_STOP_TOL) stops there. The stop
    at the geometric tail alone, as before, takes all 8 on 10 of them."""
    residual = step_residual(dmoc.discretize(arm[0], H))
    assert _eighth_updates(residual, DiracStepper(residual, 1e-12, 50), monkeypatch) == 0
    with monkeypatch.context() as patch:
        patch.setattr(fast_path, "more_updates", lambda last, before, rate_before: (
            chord_update.remaining_error(last, before) > chord_update.CHORD_STOP_TOL))
        tail_stopped = DiracStepper(residual, 1e-12, 50)
    assert _eighth_updates(residual, tail_stopped, monkeypatch) >= 5


def test_an_update_at_the_floor_is_judged_at_the_rate_before_it():
    """At the floor (at most 8 eps relative) the rate over the update before is noise: 4e-16
    after 3e-16 stops when the rate before was 1e-3 (tail 4e-19), not when it was 1.5e-2
    (tail 6e-18, as a 12-joint chain's step) or unknown (the first rate); above the floor
    (1e-14) the rate of the last two updates tells the tail, 0.75 here, whatever came before
    (a rate before of 1e-5 would give a tail of 1e-19, below the stop)."""
    def more(last, before, rate_before):
        return bool(chord_update.more_updates(ca.DM(last), ca.DM(before), ca.DM(rate_before)))
    assert not more(4e-16, 3e-16, 1e-3)
    assert more(4e-16, 3e-16, 1.5e-2) and more(4e-16, 3e-16, np.inf)
    assert more(1e-14, 1.33e-14, 1e-5)
    assert not more(1e-17, 1e-14, 0.5)        # the tail itself: 1e-20
