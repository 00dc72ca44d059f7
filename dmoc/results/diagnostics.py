"""Diagnostics of a computed Trajectory: energy, discrete constraint violation (28) and the
step residual norms of (37)/(41), each evaluated by mapping a CasADi Function over steps;
an optimum's replay by `simulate`; the interpolants' velocities at the knots
(`knot_velocities`, re-exported here with the rest of `dmoc.diagnostics`).
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.numeric import per_step
from ..discrete import Discretization
from ..errors import InputError
from ..principle.formulations import as_formulation
from ..optimal_control.statement.problem import OptimalControlProblem
from ..principle.residual import step_residual
from ..simulation.lockstep import simulate_lockstep
from ..simulation.preparation import prepare_runs
from ..simulation.time_stepping import simulate
from ..principle.trajectory import Trajectory, check_trajectory, constraint_violation  # noqa: F401 (re-exported)
from .knot_velocities import end_velocities, velocity_changes, velocity_jumps  # noqa: F401 (re-exported)


def energy(disc, traj):
    """Energy E = v . dL/dv - L of each step, shape (N,): averaged over the step by the
    rule's quadrature on its interpolant (`Discretization.step_energy`; for the midpoint
    rule E at ((q_k + q_{k+1})/2, (q_{k+1} - q_k)/h)), accurate at the rule's order. It
    needs no Legendre transform and works for degenerate Lagrangians.
    """
    if not check_trajectory(disc, traj):
        return np.zeros(0)
    (E,) = per_step(disc.step_energy, traj.steps, traj.q[:-1], traj.p[:-1], traj.q[1:],
                    traj.p[1:], traj.s, traj.h)
    return E.ravel()


def energy_drift_rate(disc, traj):
    """The energy's drift per unit time relative to its size: the slope of the least-squares
    line through the step energies (`energy`) at the step midpoints, divided by max_k |E_k|.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory
        An unforced run (with controls the energy changes by their work), at least 2 steps.

    Returns
    -------
    float
        dE/dt / max|E|, in 1/(unit of time); negative when the energy falls.

    Notes
    -----
    A nonholonomic integrator is not symplectic, and whether its energy drifts depends on
    the system, not only on the rule: on reversible systems (the knife edge, the rolling
    disk, a car with its centre of mass on the rear axle) the step energy oscillates at
    O(h^r) without drift, and the fitted rate is the oscillation's bias over the run, of the
    order of its amplitude divided by the duration; a car with its centre of mass ahead of
    the axle loses energy steadily under every rule, at a rate of order h^r (docs/stages/
    simulate.md, "Energy"; McLachlan and Perlmutter 2006, Modin and Verdier 2020).

    >>> import dmoc
    >>> disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    >>> traj = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=100).trajectory
    >>> abs(energy_drift_rate(disc, traj)) < 1e-12
    True
    """
    E = energy(disc, traj)
    if E.size < 2:
        raise InputError(f"`traj` must have at least 2 steps to fit a drift; got {E.size}.")
    t = 0.5 * (traj.t[:-1] + traj.t[1:])
    slope = np.polyfit(t - t.mean(), E, 1)[0]
    return float(slope / max(np.abs(E).max(), np.finfo(float).tiny))


def mean_momenta(disc, traj):
    """Momenta at the nodes q_0 ... q_{N-1} that approximate the continuous p(t_k) at the
    rule's order, shape (N, n): at interior nodes the mean of the momenta before and after
    the constraint impulse, p_k + impulse_side A(q_k)^T iota_k; at q_0 the momentum before
    the first impulse, the start datum (dL/dv(q_0, v_0) of a simulation or of the boundary
    rows).

    p_k of the (+) form is the momentum just before the impulse at q_k, p_k of the (-)
    form the one just after; each differs from p(t_k) by half the impulse, O(h) when the
    constraint force is not zero. The mean needs no Legendre transform and converges at
    order 2 for the midpoint and trapezoid rules and 4 for the Lobatto rules (measured;
    docs/theory.md, "Stage rules"). Without constraints it is p_k.
    """
    if not check_trajectory(disc, traj):
        return np.zeros((0, disc.system.n))
    formulation, N = as_formulation(traj.variant, disc), traj.steps
    iota = formulation.node_impulses(traj.lam, traj.mu, disc.system.m)
    A = np.array(disc.system.constraint_matrix.map(N)(traj.q[:-1].T))      # (m, N n)
    n = disc.system.n
    forces = np.array([A[:, k * n:(k + 1) * n].T @ iota[k] for k in range(N)]).reshape(N, n)
    side = np.full((N, 1), formulation.impulse_side)
    side[0] += 0.5
    return traj.p[:-1] + side * forces


def residual_norms(disc, traj):
    """Max-norm of the step residual R of (37)/(41) at every step, shape (N,)."""
    if not check_trajectory(disc, traj):
        return np.zeros(0)
    R = step_residual(disc, traj.variant).function.map(traj.steps)
    r = np.array(R(q0=traj.q[:-1].T, p0=traj.p[:-1].T, q1=traj.q[1:].T, p1=traj.p[1:].T,
                   lam=traj.lam.T, s=traj.s.T, u=traj.u.T, h=traj.h)["r"])
    return np.abs(r).max(axis=0)


def replay(problem, result):
    """The Trajectory `simulate` computes from the optimum's initial state (q_0, p_0) with its
    controls, by the problem's rule and variant and the optimum's step; it stops early
    (fewer steps) where Newton's method fails. It runs in CasADi's virtual machine
    (``jit=False``): preparing the compiled step (serializing its Functions for the cache
    key) costs more than the N steps of an optimum (benchmarks/verdict.py). The
    one-optimum case of `replays`."""
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    traj = checks.instance("result.trajectory", getattr(result, "trajectory", None), Trajectory,
                            "a Trajectory (give the OptimizationResult of `problem`)")
    return replays([(problem, traj)])[0]


def replays(pairs):
    """`replay` of each (problem, optimal Trajectory) of `pairs`, a list of Trajectories:
    the runs of one discretization and step checked together (`prepare_runs`) and all
    stepped in lockstep (`simulate_lockstep`: those of one stepper, h and N together),
    each run what `simulate` computes for it bit for bit. Raises the error of the first
    run `simulate` would refuse, as `simulate` raises it."""
    found = {}
    for i, (problem, traj) in enumerate(pairs):
        found.setdefault((id(problem.disc), traj.h), []).append(i)
    runs = [None] * len(pairs)
    for members in found.values():
        first, traj = pairs[members[0]]
        prepared = prepare_runs(first.disc.with_step(traj.h), [
            dict(q0=t.q[0], p0=t.p[0], steps=t.steps, controls=t.u, variant=t.variant,
                 throw=False, jit=False) for t in (pairs[i][1] for i in members)])
        for i, run in zip(members, prepared):
            runs[i] = run
    for run in runs:
        if isinstance(run, Exception):
            raise run
    return [result.trajectory for result in simulate_lockstep(runs)]


def replay_error(problem, result):
    """Max |q - q_opt| and |p - p_opt| when `simulate` replays the optimal controls from the
    optimal initial state (`replay`): the two consumers share one residual, so both are at
    solver tolerance. p_N is left out where the formulation puts the end impulse into it
    (variant "-"), which `simulate` cannot know; a replay that stops early gives inf."""
    simulated = replay(problem, result)       # checks both arguments
    traj = result.trajectory
    if simulated.steps < traj.steps:
        return np.inf, np.inf
    last = compared_momenta(problem, traj)
    return (float(np.abs(simulated.q - traj.q).max()),
            float(np.abs(simulated.p[:last] - traj.p[:last]).max()))


def compared_momenta(problem, traj):
    """How many of p_0 ... p_N a replay reproduces: N + 1, or N where the formulation puts
    the end impulse into p_N (variant "-"). InputTypeError unless `problem` is an
    OptimalControlProblem and `traj` a Trajectory (not their forms on SO(3))."""
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    return traj.steps + as_formulation(traj.variant, problem.disc).end_momentum_determined


def optimization_summary(problem, result):
    """Key figures of an optimization result: a dict of cost, IPOPT iterations and status,
    build and solve times, max |omega_d|, max step residual, max constraint violation of
    the NLP, the replay errors of `replay_error` and the largest of `velocity_jumps`."""
    replay_q, replay_p = replay_error(problem, result)       # checks both arguments
    traj = result.trajectory
    return {"cost": result.cost, "iterations": result.stats["iterations"],
            "status": result.status, "build_time": result.stats["build_time"],
            "solve_time": result.stats["solve_time"],
            "max_omega_d": float(constraint_violation(problem.disc, traj).max()),
            "max_residual": float(residual_norms(problem.disc, traj).max()),
            "max_violation": result.stats["max_violation"],
            "replay_q": replay_q, "replay_p": replay_p,
            "max_velocity_jump": float(velocity_jumps(traj).max(initial=0.0))}


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

    J comes from the implicit function theorem on the step residual at the computed step,
    the stage unknowns of a stage rule eliminated with (q1, p1). `u` holds the step's
    controls, shape (disc.n_controls,) (default zeros).
    """
    sys = checks.instance("disc", disc, Discretization, "a Discretization").system
    if sys.m:
        raise InputError("`disc` must have no constraints: with constraints the step map is "
                         "not symplectic on T*Q.")
    u = np.zeros(disc.n_controls) if u is None else checks.array("u", u, (disc.n_controls,))
    traj = simulate(disc, q0=q0, p0=p0, steps=1, controls=np.reshape(u, (1, -1)),
                    variant=variant).trajectory
    n = sys.n
    x = ca.SX.sym("x", 2 * n)                       # (q0, p0)
    y = ca.SX.sym("y", 2 * n + disc.n_stages)       # (q1, p1, s)
    R = step_residual(disc, variant)(q0=x[:n], p0=x[n:], q1=y[:n], p1=y[n:2 * n], lam=ca.SX(0, 1),
                                     s=y[2 * n:], u=u, h=disc.h)
    jac = ca.Function("step_jacobians", [x, y], [ca.jacobian(R, x), ca.jacobian(R, y)])
    Rx, Ry = (np.array(J) for J in jac(np.r_[traj.q[0], traj.p[0]],
                                        np.r_[traj.q[1], traj.p[1], traj.s[0]]))
    J = -np.linalg.solve(Ry, Rx)[:2 * n]
    Omega = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    return float(np.abs(J.T @ Omega @ J - Omega).max())
