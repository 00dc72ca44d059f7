"""Diagnostics of a computed Trajectory: energy, discrete constraint violation (28) and the
step residual norms of (37)/(41), each evaluated by mapping a CasADi Function over steps.
"""

import numpy as np

from .discrete import Discretization
from .principle import step_residual
from .trajectory import Trajectory


def _checked(disc, traj):
    if not isinstance(disc, Discretization):
        raise TypeError(f"`disc` must be a Discretization; got {type(disc).__name__}.")
    if not isinstance(traj, Trajectory):
        raise TypeError(f"`traj` must be a Trajectory; got {type(traj).__name__}.")
    if traj.q.shape[1] != disc.system.n:
        raise ValueError(f"`traj` has n = {traj.q.shape[1]}; the system has n = {disc.system.n}.")
    return traj.q[:-1].T, traj.q[1:].T


def energy(disc, traj):
    """Energy E = v . dL/dv - L at each step's midpoint, shape (N,).

    Evaluated at ((q_k + q_{k+1})/2, (q_{k+1} - q_k)/h), so it needs no Legendre
    transform and works for degenerate Lagrangians.
    """
    q0, q1 = _checked(disc, traj)
    E = disc.system.energy.map(traj.steps)((q0 + q1) / 2, (q1 - q0) / traj.h)
    return np.array(E).ravel()


def constraint_violation(disc, traj):
    """max_a |omega_d^a(q_k, q_{k+1})| of (28) for each step, shape (N,)."""
    q0, q1 = _checked(disc, traj)
    if disc.system.m == 0:
        return np.zeros(traj.steps)
    omega = np.array(disc.discrete_constraint.map(traj.steps)(q0, q1, traj.h))
    return np.abs(omega).max(axis=0)


def residual_norms(disc, traj):
    """Max-norm of the step residual R of (37)/(41) at every step, shape (N,)."""
    q0, q1 = _checked(disc, traj)
    R = step_residual(disc, traj.variant).function.map(traj.steps)
    r = np.array(R(q0, traj.p[:-1].T, q1, traj.p[1:].T, traj.lam.T, traj.s.T, traj.u.T, traj.h))
    return np.abs(r).max(axis=0)
