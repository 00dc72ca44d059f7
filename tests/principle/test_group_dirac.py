"""The discrete Dirac structure on SO(3) x R^n_x, left-trivialized (docs/theory.md, "The
discrete Dirac structure on the group"): the (+) Dirac differential of the group step
against the closed form of the Lie group variational integrator written here, and the
membership (36) of every step of `simulate` results (free body, heavy top, Chaplygin
sphere, a spacecraft in space under body-frame controls), which a nudge of 1e-6 to a
momentum or a rotation breaks at its size, while a momentum moved within the annihilator
range A(q)^T, the freedom of (32), is not seen."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmoc
from dmoc.dirac import dirac_defect
from dmoc.principle.group_dirac import dirac_defect_on_group, dirac_differential_on_group

R0 = Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix()
J, MASS = np.array([1.0, 2.0, 3.0]), 1.7


def hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def vee_skew(B):
    """w with w^ = (B - B^T) / 2."""
    S = 0.5 * (B - B.T)
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


def cayley(f):
    return np.linalg.solve(np.eye(3) - hat(f) / 2, np.eye(3) + hat(f) / 2)


@pytest.mark.parametrize("seed", [0, 1])
def test_differential_is_the_closed_form_of_the_group_step(seed):
    """For L_d = (1/h) tr((I - F) J_d) + (m/2h)|dx|^2 and the body-frame controls of the
    spacecraft in space (f^- = (h/2)(tau, R_k F_b), f^+ = (h/2)(tau, R_{k+1} F_b)), the
    left-trivialized derivatives are D1 L_d = -(2/h) vee(F J_d), D2 L_d = (2/h) vee(J_d F)
    (vee of the skew part; the variations F -> (I - eps eta^) F and F (I + eps eta^)), and
    D1 = -m dx/h, D2 = m dx/h on x; c1 = D2 L_d + f^+, c2 = -D1 L_d - f^-, c3 = q_k tau(f)."""
    rng = np.random.default_rng(seed)
    disc = dmoc.discretize(dmoc.systems.spacecraft(J, mass=MASS), 0.1)
    R, x, f, dx, u = (Rotation.random(random_state=seed).as_matrix(), *rng.normal(size=(3, 3)),
                      rng.normal(size=6))
    h, F, J_d = disc.h, cayley(f), 0.5 * J.sum() * np.eye(3) - np.diag(J)
    R1 = R @ F
    c0, c1, c2, c3 = (np.array(c).ravel() for c in dirac_differential_on_group(disc)(
        np.r_[R.ravel(), x], np.r_[f, dx], u, h))
    assert np.array_equal(c0, np.r_[R.ravel(), x])
    assert np.abs(c3 - np.r_[R1.ravel(), x + dx]).max() <= 1e-14
    want1 = np.r_[2 / h * vee_skew(J_d @ F) + h / 2 * u[:3], MASS * dx / h + h / 2 * R1 @ u[3:]]
    want2 = np.r_[2 / h * vee_skew(F @ J_d) - h / 2 * u[:3], MASS * dx / h - h / 2 * R @ u[3:]]
    assert np.abs(c1 - want1).max() <= 1e-12 and np.abs(c2 - want2).max() <= 1e-12


def _runs():
    """name -> (disc, q0, v0, controls) of 60-step runs."""
    top = dmoc.systems.heavy_top((1.0, 1.2, 0.4), 1.0, (0.05, 0.0, 0.5))
    r, m, Jb = 0.7, 1.3, np.array([1.0, 1.5, 2.5])
    Omega = np.array([1.0, -0.5, 2.0])
    rolling = np.r_[Omega, r * np.cross(R0 @ Omega, [0, 0, 1])[:2]]
    thrust = np.column_stack([np.sin(0.1 * np.arange(60))] * 6) * [0.1, 0.2, -0.1, 0.5, 0.1, 1.0]
    return {"free body": (dmoc.discretize(dmoc.systems.free_rigid_body(J), 0.05), R0,
                          [1.0, 0.3, -0.7], None),
            "heavy top": (dmoc.discretize(top, 0.01), R0, [0.5, -0.3, 8.0], None),
            "Chaplygin sphere": (dmoc.discretize(dmoc.systems.chaplygin_sphere(Jb, m, r), 0.05),
                                 (R0, [0.2, -0.1]), rolling, None),
            "spacecraft in space": (dmoc.discretize(dmoc.systems.spacecraft(J, mass=MASS), 0.05),
                                    (R0, [1.0, 2.0, 3.0]), [1.0, 0.3, -0.7, 0.5, 0.0, 0.0], thrust)}


@pytest.fixture(scope="module")
def runs():
    return {name: (disc, dmoc.simulate(disc, q0=q0, v0=v0, steps=60, controls=u).trajectory)
            for name, (disc, q0, v0, u) in _runs().items()}


def _rotated(R, angle_vector):
    return R @ Rotation.from_rotvec(angle_vector).as_matrix()


@pytest.mark.parametrize("name", list(_runs()))
def test_every_step_lies_in_the_discrete_dirac_structure(runs, name):
    disc, traj = runs[name]
    defect = dirac_defect(disc, traj)
    assert defect.shape == (60,) and defect.max() <= 1e-12
    assert np.array_equal(defect, dirac_defect_on_group(disc, traj))


@pytest.mark.parametrize("name", list(_runs()))
@pytest.mark.parametrize("nudged", ["momentum", "rotation"])
def test_a_nudge_of_1e_6_is_seen_at_its_size(runs, name, nudged):
    """Nudging Pi_7 by 1e-6 (along ker A_Omega(q_7), so that (dPi, 0) is orthogonal to
    the annihilator range A(q_7)^T) or R_7 (by a rotation of 1e-6 rad) breaks steps 6 and 7
    only."""
    disc, traj = runs[name]
    traj = dmoc.RotationTrajectory(traj.t, traj.R, traj.Pi, traj.f, traj.u, traj.h, traj.x,
                                   traj.p_x, traj.lam)    # a checked copy
    if nudged == "momentum":
        body = disc.system
        A_Omega = np.array(body.constraint_matrix(traj.q[7])).reshape(body.m, body.n)[:, :3]
        kick = np.linalg.svd(np.vstack([A_Omega, np.zeros((1, 3))]))[2][-1]
        assert np.abs(A_Omega @ kick).max(initial=0.0) <= 1e-12
        traj.Pi[7] += 1e-6 * kick / np.abs(kick).max()
    else:
        traj.R[7] = _rotated(traj.R[7], [0.0, 1e-6, 0.0])
    defect = dirac_defect(disc, traj)
    assert 0.3e-6 <= defect[[6, 7]].min() and defect[[6, 7]].max() <= 3e-6, defect[[6, 7]]
    assert np.delete(defect, [6, 7]).max() <= 1e-12


def test_the_annihilator_freedom_is_not_seen(runs):
    """The (+) form's p_0 is free up to A(q_0)^T lam (it enters only step 0, as the
    annihilator part): moving it along range A(q_0)^T leaves every step in the structure,
    moving it by as much across that range does not."""
    disc, traj = runs["Chaplygin sphere"]
    A = np.array(disc.system.constraint_matrix(traj.q[0])).reshape(2, 5)
    along, across = A.T @ [1e-6, -2e-6], np.linalg.svd(A)[2][-1] * 1e-6
    for kick, seen in ((along, False), (across, True)):
        moved = dmoc.RotationTrajectory(traj.t, traj.R, traj.Pi + np.r_[[kick[:3]], np.zeros((60, 3))],
                                        traj.f, traj.u, traj.h, traj.x,
                                        traj.p_x + np.r_[[kick[3:]], np.zeros((60, 2))], traj.lam)
        defect = dirac_defect(disc, moved)
        assert (defect[0] >= 0.3 * np.abs(kick).max()) == seen, defect[0]
        assert defect[1:].max() <= 1e-12


def test_refuses_what_is_not_on_the_group(runs):
    disc, traj = runs["free body"]
    with pytest.raises(TypeError, match="traj"):
        dirac_defect_on_group(disc, "not a trajectory")
    with pytest.raises(TypeError, match="disc"):
        dirac_defect_on_group(dmoc.discretize(dmoc.systems.knife_edge(), 0.1), traj)
    other, _ = runs["spacecraft in space"]
    with pytest.raises(ValueError, match="traj.f"):
        dirac_defect_on_group(other, traj)
