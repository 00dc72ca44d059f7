"""Trajectory.sample, the dense solution between the knots: at the knots it returns the
stored q, p and the stored controls at their nodes; between the knots q, v and p converge
at the orders its docstring states, for every rule.

Oracle: the knife edge on a plane inclined by alpha under constant controls, its reduced
equations derived here (no sideways slip: xdot = sigma cos theta, ydot = sigma sin theta,
m sigma' = u0 - m g sin(alpha) cos theta, J omega' = u1, p = (m xdot, m ydot, J omega)),
integrated by scipy's DOP853 at rtol 1e-12. The incline's potential tells the midpoint and
trapezoid rules apart. The discrete momenta p_k carry a constraint impulse along A(q)^T of
size O(h) (they are fixed up to A(q_k)^T lam by the discrete principle), so p is compared
on the allowed directions ker A(q) = span{(cos theta, sin theta, 0), (0, 0, 1)}; p_0 is the
given momentum, without that impulse, so on the first d steps, whose stencils hold p_0, p
is only O(h^2) (d the interpolant's degree). A second oracle, two formulations that must
agree: the discrete Legendre transform of lobatto3, whose stages hold one more block,
runs the Lagrangian trajectory, so both dense solutions must be the same.
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc

MASS, INERTIA, INCLINE, GRAVITY = 1.3, 0.7, 0.4, 9.81
U = np.array([0.8, 0.5])                    # (force along the blade, torque), held constant
Q0, SIGMA0, OMEGA0, T = np.array([0.1, -0.2, 0.3]), 1.0, 0.6, 2.0
# declared orders (q, v, p after the first d steps) between the knots: Trajectory.sample's
# docstring
ORDERS = {"midpoint": (2, 1, 2), "trapezoid": (2, 1, 2), "lobatto3": (3, 2, 3), "lobatto4": (4, 3, 4)}
STEPS = np.array([16, 32, 64, 128])


def knife_edge_flow(times):
    """(q, v, p) at `times`, each (K, 3), by DOP853 on the reduced equations."""
    a = GRAVITY * np.sin(INCLINE)

    def rhs(t, z):
        x, y, theta, sigma, omega = z
        return [sigma * np.cos(theta), sigma * np.sin(theta), omega,
                U[0] / MASS - a * np.cos(theta), U[1] / INERTIA]
    sol = solve_ivp(rhs, (0.0, T), [*Q0, SIGMA0, OMEGA0], method="DOP853", t_eval=times,
                    rtol=1e-12, atol=1e-12)
    x, y, theta, sigma, omega = sol.y
    v = np.column_stack([sigma * np.cos(theta), sigma * np.sin(theta), omega])
    return sol.y[:3].T, v, v * [MASS, MASS, INERTIA]


def simulated(rule, steps):
    system = dmoc.systems.knife_edge(mass=MASS, inertia=INERTIA, incline=INCLINE, gravity=GRAVITY)
    disc = dmoc.discretize(system, T / steps, rule)
    v0 = [SIGMA0 * np.cos(Q0[2]), SIGMA0 * np.sin(Q0[2]), OMEGA0]
    return dmoc.simulate(disc, q0=Q0, v0=v0, steps=steps, controls=np.tile(U, (steps, 1)),
                         jit=False).trajectory


@pytest.mark.parametrize("rule", list(ORDERS))
def test_sample_at_the_knots_is_the_stored_solution(rule):
    traj = simulated(rule, 8)
    at_knots = traj.sample(traj.t)
    assert np.array_equal(at_knots.q, traj.q) and np.array_equal(at_knots.p, traj.p)
    assert at_knots.t is not traj.t and np.array_equal(at_knots.t, traj.t)
    nodes = np.asarray(traj.control_nodes)
    at_nodes = traj.sample((traj.t[:-1, None] + nodes * traj.h).ravel())
    np.testing.assert_allclose(at_nodes.u.reshape(traj.steps, -1), traj.u, rtol=0, atol=1e-14)


def test_the_last_knot_is_stored_where_its_step_time_rounds_off_one():
    """t_N - t_{N-1} = 0.6 - 0.5 is (1 + 4 eps) h for h = 0.1: the last knot must still be
    the stored q_N and p_N, not the chord extrapolated by round-off."""
    rng = np.random.default_rng(3)
    t = 0.1 * np.arange(7)
    assert (t[-1] - t[-2]) / 0.1 != 1.0              # the case this test is about
    traj = dmoc.Trajectory(t, rng.normal(size=(7, 2)), rng.normal(size=(7, 2)), np.zeros((6, 0)),
                           rng.normal(size=(6, 1)), 0.1, "+")
    last = traj.sample(t[-1])
    assert np.array_equal(last.q, traj.q[-1]) and np.array_equal(last.p, traj.p[-1])


@pytest.mark.parametrize("rule", list(ORDERS))
def test_sample_converges_at_the_declared_order(rule):
    """Max error over the times t_k + 0.3 h of every step, at N = 16, 32, 64, 128; p on
    the first d steps at least second order (below twice the h^2 line through N = 16)."""
    errors = []
    for steps in STEPS:
        traj = simulated(rule, steps)
        times = traj.t[:-1] + 0.3 * traj.h
        exact = knife_edge_flow(times)
        dense = traj.sample(times)
        q, v, p = exact
        allowed = (np.column_stack([np.cos(q[:, 2]), np.sin(q[:, 2]), 0 * q[:, 2]]), [0, 0, 1])
        p_error = np.max([np.abs(((dense.p - p) * w).sum(axis=1)) for w in allowed], axis=0)
        d = len(traj.stage_nodes) + 1
        errors.append([np.abs(dense.q - q).max(), np.abs(dense.v - v).max(), p_error[d:].max(),
                       p_error[:d].max()])
    errors, first_steps = np.array(errors)[:, :3], np.array(errors)[:, 3]
    assert np.all(first_steps * STEPS ** 2 <= 2 * first_steps[0] * STEPS[0] ** 2), first_steps
    assert errors.min() > 1e-11                     # above the round-off floor
    slopes = -np.diff(np.log2(errors), axis=0)      # one halving of h per row
    observed = slopes[1:].mean(axis=0)              # the first halving may be pre-asymptotic
    np.testing.assert_allclose(observed, ORDERS[rule], rtol=0, atol=0.35,
                               err_msg=f"errors {errors.tolist()}")


def test_scalar_and_array_times_give_consistent_shapes():
    traj = simulated("lobatto3", 4)
    one, many = traj.sample(0.7), traj.sample([0.7, 1.1])
    assert isinstance(one.t, float) and one.q.shape == (3,) and one.u.shape == (2,)
    assert many.t.shape == (2,) and many.q.shape == many.v.shape == many.p.shape == (2, 3)
    assert many.u.shape == (2, 2) and traj.control(0.7).shape == (2,)
    for name in ("q", "v", "p", "u"):
        np.testing.assert_array_equal(getattr(many, name)[0], getattr(one, name))


@pytest.mark.parametrize("t, bad", [(2.5, "2.5"), ([0.5, -0.1], "-0.1"), (np.nan, "nan")])
def test_sample_outside_the_horizon_is_refused(t, bad):
    traj = simulated("midpoint", 4)
    with pytest.raises(dmoc.InputError, match=rf"`t` must lie in the horizon .* t\[\d\] = {bad} "
                                              r"is outside \(the solution is not extrapolated\)"):
        traj.sample(t)
    np.testing.assert_array_equal(traj.sample([-1e-13, T + 1e-12]).q, traj.q[[0, -1]])


@pytest.mark.parametrize("nodes", [(1.0,), (0.6, 0.3), (0.3, 0.3)])
def test_stage_nodes_are_checked(nodes):
    with pytest.raises(dmoc.InputError, match=r"`stage_nodes` must increase within \(0, 1\)"):
        dmoc.Trajectory([0, 1], [[0.0], [1.0]], [[0.0]] * 2, [[]], [[0.0]], 1.0, "+",
                        s=[[0.5, 0.5]], stage_nodes=nodes)
    with pytest.raises(dmoc.InputError, match=r"`s` must hold the 2 stage configurations"):
        dmoc.Trajectory([0, 1], [[0.0], [1.0]], [[0.0]] * 2, [[]], [[0.0]], 1.0, "+",
                        s=[[0.5]], stage_nodes=(0.3, 0.6))



def test_sample_of_the_legendre_transform_is_the_lagrangian_runs():
    """`discrete_legendre` of lobatto3 keeps the extremizing Q ahead of the rule's stage
    configuration in s (stages (Q, sigma)). From the same (q_0, p_0) it runs the Lagrangian
    trajectory (tests/discrete/test_hamiltonian.py; here L = |v|^2/2 + cos q_1 cos q_2, no
    constraints, as lobatto3's interior multipliers have no Legendre transform), so its dense
    solution at t_k + 0.3 h must be the Lagrangian run's, and its q at the stage node
    t_k + h/2 the stored sigma."""
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) + ca.cos(q[0]) * ca.cos(q[1]), 2)
    disc, steps = dmoc.discretize(system, 0.2, "lobatto3"), 8
    a, b = (dmoc.simulate(d, q0=[0.3, 0.1], p0=[0.2, -0.4], steps=steps, jit=False).trajectory
            for d in (disc, dmoc.discrete_legendre(disc)))
    assert b.s.shape == (steps, 4) and np.abs(b.s[:, :2] - b.s[:, 2:]).max() > 1e-2
    times = b.t[:-1] + 0.3 * b.h
    for name in ("q", "v", "p"):
        np.testing.assert_allclose(getattr(b.sample(times), name), getattr(a.sample(times), name),
                                   rtol=0, atol=1e-10)
    np.testing.assert_allclose(b.sample(b.t[:-1] + 0.5 * b.h).q, b.s[:, 2:], rtol=0, atol=1e-14)
