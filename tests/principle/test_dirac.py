"""Discrete Tulczyjew triples and Dirac structures (Sections 3-5 of Leok & Ohsawa):
the symplectic-form identities (20), (24), (25) of the maps kappa_d, Omega_d+-^flat, the
membership (36)/(40) of every computed step, and symplecticity without constraints."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.diagnostics import symplecticity_defect
from dmoc.dirac import dirac_defect, kappa, omega_flat_minus, omega_flat_plus

n = 3


def _matrix(linear_map):
    """The 4n x 4n matrix of a linear map (z, z+) -> 4-tuple of n-vectors."""
    columns = []
    for e in np.eye(4 * n):
        out = linear_map((e[:n], e[n:2 * n]), (e[2 * n:3 * n], e[3 * n:]))
        columns.append(np.concatenate(out))
    return np.array(columns).T


def _canonical(n_base):
    """Matrix of the canonical form sum_i dx_i ^ da_i on T*X, coordinates (x, a)."""
    I, Z = np.eye(n_base), np.zeros((n_base, n_base))
    return np.block([[Z, I], [-I, Z]])


def test_symplectic_form_identities_25():
    """(25): Omega_{T*QxT*Q} = kappa_d^* Omega = -(Omega_d+^flat)^* Omega = -(Omega_d-^flat)^* Omega,
    with Omega_{T*QxT*Q} = dq1 ^ dp1 - dq0 ^ dp0 (20), (24)."""
    # coordinates (q0, p0, q1, p1)
    I, Z = np.eye(n), np.zeros((n, n))
    omega_pair = np.block([[Z, -I, Z, Z], [I, Z, Z, Z], [Z, Z, Z, I], [Z, Z, -I, Z]])
    canonical = _canonical(2 * n)  # on T*(QxQ), T*(QxQ*), T*(Q*xQ): coordinates (x1, x2, a1, a2)
    for pullback_sign, linear_map in ((1, kappa), (-1, omega_flat_plus), (-1, omega_flat_minus)):
        M = _matrix(linear_map)
        assert np.array_equal(pullback_sign * M.T @ canonical @ M, omega_pair)


def test_maps_are_the_coordinate_maps_of_14_to_16():
    rng = np.random.default_rng(0)
    q0, p0, q1, p1 = rng.normal(size=(4, n))
    for got, want in ((kappa((q0, p0), (q1, p1)), (q0, q1, -p0, p1)),
                      (omega_flat_plus((q0, p0), (q1, p1)), (q0, p1, p0, q1)),
                      (omega_flat_minus((q0, p0), (q1, p1)), (p0, q1, -q0, -p1))):
        for a, b in zip(got, want):
            assert np.array_equal(a, b)


def _runs():
    knife = dmoc.systems.knife_edge(incline=0.3)
    disk = dmoc.systems.rolling_disk()
    return {"knife_edge": (knife, [0, 0, 0.2], [np.cos(0.2), np.sin(0.2), 1.0]),
            "rolling_disk": (disk, [0, 0, 0, 0.3], [np.cos(0.3), np.sin(0.3), 1.0, 0.7])}


@pytest.mark.parametrize("name", ["knife_edge", "rolling_disk"])
@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
def test_every_step_lies_in_the_discrete_dirac_structure(name, variant, rule):
    system, q0, v0 = _runs()[name]
    disc = dmoc.discretize(system, 0.05, rule)
    controls = np.column_stack([np.sin(np.arange(200) * 0.05), 0.3 * np.ones(200)])
    traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=200, controls=controls,
                         variant=variant).trajectory
    assert dirac_defect(disc, traj).max() < 1e-12
    # A perturbation of one momentum outside range A(q)^T is detected at its size.
    A = np.array(system.constraint_matrix(traj.q[7]))
    kick = np.linalg.svd(A)[2][-1] * 1e-6          # a direction in ker A, orthogonal to range A^T
    traj.p[7] += kick
    defect = dirac_defect(disc, traj)
    assert defect[[6, 7]].max() == pytest.approx(1e-6, rel=0.3)
    assert np.delete(defect, [6, 7]).max() < 1e-12


@pytest.mark.parametrize("rule", ["midpoint", "trapezoid"])
@pytest.mark.parametrize("variant", ["+", "-"])
def test_unconstrained_step_map_is_symplectic(rule, variant):
    """No constraints: (37)/(41) is a variational integrator, J^T Omega J = Omega (20).
    Checked two ways: the implicit-function Jacobian, and central differences of simulate."""
    system = dmoc.MechanicalSystem(
        lambda q, v: 0.5 * (2 * v[0] ** 2 + v[1] ** 2 + v[0] * v[1]) - ca.cos(q[0]) * q[1] ** 2 - q[0] ** 4, 2)
    disc = dmoc.discretize(system, 0.1, rule)
    z = np.array([0.3, 0.5, 0.2, -0.4])
    assert symplecticity_defect(disc, z[:2], z[2:], variant=variant) < 1e-13

    def step(z):
        t = dmoc.simulate(disc, q0=z[:2], p0=z[2:], steps=1, variant=variant).trajectory
        return np.r_[t.q[1], t.p[1]]

    eps = 1e-5
    J = np.column_stack([(step(z + eps * e) - step(z - eps * e)) / (2 * eps) for e in np.eye(4)])
    Omega = _canonical(2)
    assert np.abs(J.T @ Omega @ J - Omega).max() < 1e-8


def test_dissipation_breaks_symplecticity():
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) - ca.cos(q[0]), 2,
                                   force=lambda q, v, u: -0.5 * v)
    assert symplecticity_defect(dmoc.discretize(system, 0.1), [0.3, 0.5], [0.2, -0.4]) > 1e-2


def test_symplecticity_defect_rejects_constraints():
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    with pytest.raises(ValueError, match="disc"):
        symplecticity_defect(disc, [0, 0, 0], [1, 0, 0])


@pytest.mark.parametrize("name", ["knife_edge", "rolling_disk"])
@pytest.mark.parametrize("variant", ["+", "-"])
def test_defect_sees_a_kick_only_the_annihilator_distance_can_see(name, variant):
    """A kick to the momentum at the d'Alembert node that enters one component only: the
    free one (the fibre allowed to differ by A(q)^T lam). For (+) that is p_0, which enters
    only step 0, as component 2 = -D1 L_d - f^- - p_0 (free up to A(q_0)^T lam); for (-)
    it is p_N, which enters only step N-1, as component 3 = -D2 L_d - f^+ + p_N (free up
    to A(q_N)^T lam). Every other mismatch and omega_d stay exactly as they were, so only
    the distance to range A(q)^T can flag it: a kick in ker A(q) (orthogonal to the range)
    is seen at its full size, and a kick in range A(q)^T is not seen at all."""
    system, q0, v0 = _runs()[name]
    disc = dmoc.discretize(system, 0.05)
    traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=40, variant=variant).trajectory
    node, step = (0, 0) if variant == "+" else (traj.steps, traj.steps - 1)
    A = np.array(system.constraint_matrix(traj.q[node]))
    off_range = np.linalg.svd(A)[2][-1] * 1e-6          # in ker A, orthogonal to range A^T
    in_range = A.T @ np.linspace(1.0, 2.0, A.shape[0]) * 1e-3
    p = traj.p.copy()
    traj.p[node] = p[node] + off_range
    defect = dirac_defect(disc, traj)
    assert defect[step] == pytest.approx(np.abs(off_range).max(), rel=1e-6)
    assert np.delete(defect, step).max() < 1e-12
    traj.p[node] = p[node] + in_range
    assert dirac_defect(disc, traj).max() < 1e-12
