"""Diagnostics of a computed Trajectory: energy, discrete constraint violation (28) and the
step residual norms of (37)/(41), each evaluated by mapping a CasADi Function over steps.
"""

import casadi as ca
import numpy as np

from . import _checks
from .discrete import Discretization, discretize
from .formulations import as_formulation
from .principle import step_residual
from .simulate import simulate
from .trajectory import Trajectory


def check_trajectory(disc, traj):
    """Raise unless `traj` fits `disc` (sizes of q, lam, u, s); return its number of steps."""
    if not isinstance(disc, Discretization):
        raise TypeError(f"`disc` must be a Discretization; got {type(disc).__name__}.")
    if not isinstance(traj, Trajectory):
        raise TypeError(f"`traj` must be a Trajectory; got {type(traj).__name__}.")
    sizes = {"q": disc.system.n, "lam": disc.n_multipliers, "u": disc.n_controls, "s": disc.n_stages}
    for name, size in sizes.items():
        if getattr(traj, name).shape[1] != size:
            raise ValueError(f"`traj.{name}` has {getattr(traj, name).shape[1]} columns; "
                             f"this discretization has {size}.")
    return traj.steps


def energy(disc, traj):
    """Energy E = v . dL/dv - L at each step's midpoint, shape (N,).

    Evaluated on the rule's interpolant in the middle of the step (for linear rules at
    ((q_k + q_{k+1})/2, (q_{k+1} - q_k)/h)), so it needs no Legendre transform and works
    for degenerate Lagrangians.
    """
    if not check_trajectory(disc, traj):
        return np.zeros(0)
    q, v = disc.midpoint_state.map(traj.steps)(traj.q[:-1].T, traj.q[1:].T, traj.s.T, traj.h)
    return np.array(disc.system.energy.map(traj.steps)(q, v)).ravel()


def constraint_violation(disc, traj):
    """max_a |omega_d^a| of (28) (or of the stage rule's moment rows) for each step, shape (N,)."""
    if not check_trajectory(disc, traj) or disc.system.m == 0:
        return np.zeros(traj.steps)
    omega = np.array(disc.discrete_constraint.map(traj.steps)(traj.q[:-1].T, traj.q[1:].T,
                                                               traj.s.T, traj.h))
    return np.abs(omega).max(axis=0)


def residual_norms(disc, traj):
    """Max-norm of the step residual R of (37)/(41) at every step, shape (N,)."""
    if not check_trajectory(disc, traj):
        return np.zeros(0)
    R = step_residual(disc, traj.variant).function.map(traj.steps)
    r = np.array(R(q0=traj.q[:-1].T, p0=traj.p[:-1].T, q1=traj.q[1:].T, p1=traj.p[1:].T,
                   lam=traj.lam.T, s=traj.s.T, u=traj.u.T, h=traj.h)["r"])
    return np.abs(r).max(axis=0)


def replay_error(problem, result):
    """Max |q - q_opt| and |p - p_opt| when `simulate` replays the optimal controls from the
    optimal initial state: the two consumers share one residual, so both are at solver
    tolerance. p_N is left out where the formulation puts the end impulse into it (variant
    "-"), which `simulate` cannot know."""
    traj = result.trajectory
    disc = discretize(problem.disc.system, traj.h, problem.disc.rule)
    replay = simulate(disc, q0=traj.q[0], p0=traj.p[0], steps=traj.steps, controls=traj.u,
                      variant=traj.variant, throw=False).trajectory
    if replay.steps < traj.steps:
        return np.inf, np.inf
    last = traj.steps + as_formulation(traj.variant).end_momentum_determined
    return (float(np.abs(replay.q - traj.q).max()),
            float(np.abs(replay.p[:last] - traj.p[:last]).max()))


def optimization_summary(problem, result):
    """Key figures of an optimization result: a dict of cost, IPOPT iterations and status,
    build and solve times, max |omega_d|, max step residual, max constraint violation of
    the NLP and the replay errors of `replay_error`."""
    traj = result.trajectory
    replay_q, replay_p = replay_error(problem, result)
    return {"cost": result.cost, "iterations": result.stats["iterations"],
            "status": result.status, "build_time": result.stats["build_time"],
            "solve_time": result.stats["solve_time"],
            "max_omega_d": float(constraint_violation(problem.disc, traj).max()),
            "max_residual": float(residual_norms(problem.disc, traj).max()),
            "max_violation": result.stats["max_violation"],
            "replay_q": replay_q, "replay_p": replay_p}


def format_summary(title, figures):
    """The dict of `optimization_summary` as indented text lines under `title`."""
    return "\n".join([
        f"{title}: {figures['status']}",
        f"  cost                     {figures['cost']:.10f}",
        f"  IPOPT iterations         {figures['iterations']}",
        f"  solve time               {figures['solve_time']:.3f} s (build {figures['build_time']:.3f} s)",
        f"  max constraint violation {figures['max_violation']:.2e} (max |omega_d| {figures['max_omega_d']:.2e})",
        f"  replay by simulate       max |q - q_opt| = {figures['replay_q']:.2e}, "
        f"max |p - p_opt| = {figures['replay_p']:.2e}"])


def symplecticity_defect(disc, q0, p0, *, u=None, variant="+"):
    """max |J^T Omega J - Omega| for the step map (q0, p0) -> (q1, p1) of an unconstrained
    system, Omega the matrix of dq ^ dp (20); zero for a variational integrator.

    J comes from the implicit function theorem on the step residual at the computed step.
    """
    sys = disc.system
    if sys.m or disc.n_stages:
        raise ValueError("`disc` must have no constraints and no stages: with constraints the "
                         "step map is not symplectic on T*Q.")
    u = np.zeros(sys.n_u) if u is None else _checks.array("u", u, (sys.n_u,))
    traj = simulate(disc, q0=q0, p0=p0, steps=1, controls=np.reshape(u, (1, -1)),
                    variant=variant).trajectory
    n = sys.n
    x = ca.SX.sym("x", 2 * n)      # (q0, p0)
    y = ca.SX.sym("y", 2 * n)      # (q1, p1)
    R = step_residual(disc, variant)(q0=x[:n], p0=x[n:], q1=y[:n], p1=y[n:], lam=ca.SX(0, 1),
                                     s=ca.SX(0, 1), u=u, h=disc.h)
    jac = ca.Function("step_jacobians", [x, y], [ca.jacobian(R, x), ca.jacobian(R, y)])
    Rx, Ry = (np.array(J) for J in jac(np.r_[traj.q[0], traj.p[0]], np.r_[traj.q[1], traj.p[1]]))
    J = -np.linalg.solve(Ry, Rx)
    Omega = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    return float(np.abs(J.T @ Omega @ J - Omega).max())
