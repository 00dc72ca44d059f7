"""Degenerate Lagrangians are accepted and dL/dv is never inverted.

Oracles, none taken from the code under test: L = q0 v1 - q1 v0 - k|q|^2/2 (linear in v)
with the discrete flows derived by hand (midpoint: the Cayley rotation; trapezoid: Euler
start then leapfrog), and an LC-circuit-like L with a coordinate without kinetic term, whose
other coordinate must follow the hand-written midpoint scheme of the reduced oscillator."""

import numpy as np
import pytest

import dmoc


K_ROT = 1.7


def rotation_system():
    """L = q0 v1 - q1 v0 - K |q|^2/2: linear in v; its flow is a rotation at rate K/2."""
    return dmoc.MechanicalSystem(
        lambda q, v: q[0] * v[1] - q[1] * v[0] - K_ROT / 2 * (q[0] ** 2 + q[1] ** 2), 2)


def rotate(q, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * q[0] - s * q[1], s * q[0] + c * q[1]])


@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
@pytest.mark.parametrize("variant", ["+", "-"])
def test_lagrangian_linear_in_velocity(variant, rule):
    """p = dL/dv = (-q1, q0) whatever v is. By hand, the midpoint rows give
    q_{k+1} - q_k = (hK/2) J (q_k + q_{k+1})/2, J q = (-q1, q0): the Cayley rotation by
    2 atan(hK/4) per step. The trapezoid rows give an Euler first step and then the
    leapfrog q_{k+1} = q_{k-1} + hK J q_k."""
    h, N, q0 = 0.1, 50, np.array([1.0, 0.5])
    d = dmoc.discretize(rotation_system(), h, rule)
    res = dmoc.simulate(d, q0=q0, v0=[0.0, 0.0], steps=N, variant=variant)
    assert res.success
    if rule == "midpoint":
        want = rotate(q0, 2 * np.arctan(h * K_ROT / 4) * np.arange(N + 1))
    else:
        J = lambda q: np.array([-q[1], q[0]])  # noqa: E731
        want = [q0, q0 + h * K_ROT / 2 * J(q0)]
        for _ in range(N - 1):
            want.append(want[-2] + h * K_ROT * J(want[-1]))
    np.testing.assert_allclose(res.trajectory.q, np.array(want), rtol=0, atol=1e-12)
    # Starting from the momentum instead gives the same motion.
    again = dmoc.simulate(d, q0=q0, p0=[-q0[1], q0[0]], steps=N, variant=variant)
    np.testing.assert_allclose(again.trajectory.q, res.trajectory.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("variant", ["+", "-"])
def test_lc_circuit_like_lagrangian(variant):
    """L = v0^2/2 - k (q0 - q1)^2/2 - c q1^2/2: q1 has no kinetic term. Its midpoint row
    forces (q1 mean) = k/(k+c) (q0 mean), and q0 then follows the midpoint scheme of the
    oscillator with k_eff = k c/(k + c), written here by hand; p1 stays 0."""
    k, c, h, N = 2.0, 3.0, 0.1, 50
    system = dmoc.MechanicalSystem(
        lambda q, v: 0.5 * v[0] ** 2 - k / 2 * (q[0] - q[1]) ** 2 - c / 2 * q[1] ** 2, 2)
    res = dmoc.simulate(dmoc.discretize(system, h), q0=[1.0, 0.3], v0=[0.4, 0.0],
                        steps=N, variant=variant)
    q = res.trajectory.q
    k_eff, x, p = k * c / (k + c), [1.0], 0.4
    for _ in range(N):
        x1 = (p + x[-1] * (1 / h - h * k_eff / 4)) / (1 / h + h * k_eff / 4)
        p = (x1 - x[-1]) / h - h / 2 * k_eff * (x1 + x[-1]) / 2
        x.append(x1)
    np.testing.assert_allclose(q[:, 0], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose((q[1:, 1] + q[:-1, 1]) / 2, k / (k + c) * (q[1:, 0] + q[:-1, 0]) / 2,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.trajectory.p[:, 1], 0.0, rtol=0, atol=1e-12)
    assert np.ptp(q[:, 0]) > 0.5                     # it oscillates
