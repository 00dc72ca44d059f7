"""The compiled Dirac step (dmoc.stepper): fast unrolled Newton, line-search fallback,
chunked horizons, and the optional C compilation all give the solution of the residual."""

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

import dmoc
from dmoc.diagnostics import residual_norms
from dmoc.simulation.stepper import CHUNK

H, DRAG = 0.1, 0.4


def _nonlinear_system():
    """L = v^2/2 + cos q (pendulum), force f = DRAG v^2 + u: the step equation is nonlinear."""
    return dmoc.MechanicalSystem(lambda q, v: 0.5 * v[0] ** 2 + ca.cos(q[0]), 1,
                                 force=lambda q, v, u: DRAG * v[0] ** 2 + u[0], n_u=1)


def _by_hand(q0, p0, controls):
    """(+) midpoint steps solved one scalar equation at a time with brentq (oracle).

    With v = (q1 - q0)/h and qm = q0 + h v/2:  p0 - v - h/2 sin(qm) + h/2 (DRAG v^2 + u) = 0,
    then p1 = v - h/2 sin(qm) + h/2 (DRAG v^2 + u).
    """
    q, p = [q0], [p0]
    for u in controls[:, 0]:
        def left(v):
            return p[-1] - v - H / 2 * np.sin(q[-1] + H * v / 2) + H / 2 * (DRAG * v**2 + u)
        v = brentq(left, -5.0, 0.9 / (DRAG * H), xtol=1e-15, rtol=1e-15)  # branch through v ~ p0
        qm = q[-1] + H * v / 2
        q.append(q[-1] + H * v)
        p.append(v - H / 2 * np.sin(qm) + H / 2 * (DRAG * v**2 + u))
    return np.array(q), np.array(p)


def test_fallback_redoes_hard_steps_and_matches_the_hand_solution():
    controls = np.zeros((10, 1))
    controls[5] = 20.0             # a kick: the warm start is far off, 3 Newton steps are not enough
    disc = dmoc.discretize(_nonlinear_system(), H)
    res = dmoc.simulate(disc, q0=[0.0], v0=[1.0], steps=10, controls=controls)
    assert res.success and res.stats["robust_steps"] > 0
    q, p = _by_hand(0.0, 1.0, controls)
    assert np.abs(res.trajectory.q[:, 0] - q).max() < 1e-12
    assert np.abs(res.trajectory.p[:, 0] - p).max() < 1e-11
    assert residual_norms(disc, res.trajectory).max() < 1e-10


def test_easy_steps_take_the_fast_path():
    disc = dmoc.discretize(_nonlinear_system(), H)
    res = dmoc.simulate(disc, q0=[0.0], v0=[1.0], steps=20, controls=np.full((20, 1), 0.3))
    assert res.stats["robust_steps"] == 0
    q, _ = _by_hand(0.0, 1.0, np.full((20, 1), 0.3))
    assert np.abs(res.trajectory.q[:, 0] - q).max() < 1e-12


@pytest.mark.parametrize("variant", ["+", "-"])
def test_chunk_boundaries_are_seamless(variant):
    """A run longer than one compiled chunk equals two runs glued at an arbitrary step,
    each of them crossing chunk boundaries too. For "-" the second run's initial impulse
    is the multiplier the first run left at 0 at its last knot."""
    disc = dmoc.discretize(dmoc.systems.rolling_disk(), 0.01)
    steps, cut = CHUNK + 700, 600
    controls = np.column_stack([np.sin(0.01 * np.arange(steps)), np.cos(0.02 * np.arange(steps))])
    start = dict(q0=[0, 0, 0, 0], v0=[1, 0, 1, 0.5], variant=variant)
    whole = dmoc.simulate(disc, steps=steps, controls=controls, **start).trajectory
    first = dmoc.simulate(disc, steps=cut, controls=controls[:cut], **start).trajectory
    second = dmoc.simulate(disc, q0=first.q[-1], p0=first.p[-1], steps=steps - cut,
                           controls=controls[cut:], variant=variant).trajectory
    assert np.abs(np.vstack([first.q, second.q[1:]]) - whole.q).max() < 1e-12
    assert np.abs(np.vstack([first.p[:-1], second.p]) - whole.p).max() < 1e-12
    if variant == "+":
        assert np.abs(np.vstack([first.lam, second.lam]) - whole.lam).max() < 1e-12
    else:
        glued = np.vstack([first.lam[:-1], second.mu, second.lam])
        assert np.abs(glued - whole.lam).max() < 1e-12
        assert np.abs(first.mu - whole.mu).max() < 1e-12


@pytest.mark.parametrize("variant", ["+", "-"])
def test_compiled_step_gives_the_same_trajectory(variant):
    disc = dmoc.discretize(dmoc.systems.knife_edge(incline=0.2), 0.02)
    controls = np.column_stack([np.sin(0.02 * np.arange(300)), np.ones(300)])
    runs = [dmoc.simulate(disc, q0=[0, 0, 0.1], v0=[np.cos(0.1), np.sin(0.1), 1.0], steps=300,
                          controls=controls, variant=variant, jit=jit).trajectory
            for jit in (False, True)]
    for field in ("q", "p", "lam"):
        assert np.abs(getattr(runs[0], field) - getattr(runs[1], field)).max() < 1e-12
