"""Consumer 2 of the step residual, its solver half: `optimize` solves an
OptimalControlProblem with IPOPT (casadi.nlpsol, exact Hessian) from a guess, and returns
the optimal Trajectory, or raises SolverError carrying the last iterate and naming the most
violated constraint group (dynamics at step k, boundary, path).
"""

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from . import _checks
from .ocp import OptimalControlProblem
from .errors import SolverError
from .trajectory import Trajectory

# honor_original_bounds: IPOPT relaxes bounds by bound_relax_factor while iterating; project
# the final point back so that bounds on states, controls and the final time hold exactly.
DEFAULT_IPOPT_OPTIONS = {"tol": 1e-10, "constr_viol_tol": 1e-10, "print_level": 0, "sb": "yes",
                         "max_iter": 1000, "honor_original_bounds": "yes"}


@dataclass
class OptimizationResult:
    """Outcome of `optimize`.

    Attributes
    ----------
    trajectory : Trajectory
        The optimal trajectory, or the last iterate when not `success`.
    cost : float
    success : bool
    status : str
        IPOPT's return status, e.g. ``"Solve_Succeeded"``.
    message : str
    stats : dict
        ``iterations``, ``return_status``, ``build_time`` (seconds to create the solver),
        ``solve_time`` (wall seconds in IPOPT), ``max_violation`` (of all constraints),
        ``most_violated`` (group, step, row).
    x : ndarray
        The raw NLP vector; ``problem.x_layout.unpack(x, name)`` reads any block (e.g. the
        end impulse ``"nu"``).
    """

    trajectory: Trajectory
    cost: float
    success: bool
    status: str
    message: str
    stats: dict = field(default_factory=dict)
    x: np.ndarray = None


def optimize(problem, *, guess=None, options=None, throw=True):
    """Solve a DMOC problem with IPOPT.

    Parameters
    ----------
    problem : OptimalControlProblem
    guess : Trajectory, optional
        Initial guess (resampled in time if its number of steps differs). By default the
        configurations interpolate linearly between the boundary data, bent by a small
        sine bump so the guess avoids points where the constraint Jacobian is singular
        (e.g. the knife edge sliding straight sideways).
    options : dict, optional
        IPOPT options overriding ``DEFAULT_IPOPT_OPTIONS`` (e.g. ``{"print_level": 5}``),
        and ``"expand"`` (bool, default False: keep the mapped MX graph; True expands it
        to SX, 1.3-3x faster per IPOPT iteration but 2.7-3.8x slower to build at N >= 400;
        both build times grow linearly with N, see docs/performance.md).
    throw : bool
        Raise SolverError when IPOPT fails (default); else return with success=False.

    Returns
    -------
    OptimizationResult
    """
    if not isinstance(problem, OptimalControlProblem):
        raise TypeError(f"`problem` must be an OptimalControlProblem; got {type(problem).__name__}.")
    throw = _checks.boolean("throw", throw)
    if guess is not None and not isinstance(guess, Trajectory):
        raise TypeError(f"`guess` must be a Trajectory or None; got {type(guess).__name__}.")
    if options is not None and not isinstance(options, dict):
        raise TypeError(f"`options` must be a dict of IPOPT options; got {type(options).__name__}.")
    tic = time.perf_counter()
    solver = _solver(problem, dict(options or {}))
    build_time = time.perf_counter() - tic
    x0 = initial_guess(problem, guess)
    tic = time.perf_counter()
    sol = solver(x0=x0, lbx=problem.lbx, ubx=problem.ubx, lbg=problem.lbg, ubg=problem.ubg)
    solve_time = time.perf_counter() - tic
    x = np.array(sol["x"]).ravel()
    st = solver.stats()
    worst = most_violated(problem, np.array(sol["g"]).ravel())
    stats = {"iterations": st.get("iter_count"), "return_status": st["return_status"],
             "build_time": build_time, "solve_time": solve_time,
             "max_violation": worst[0], "most_violated": worst[1]}
    traj = trajectory_from_x(problem, x)
    success = bool(st["success"])
    where = f"; most violated: {worst[1]} (|violation| = {worst[0]:.2e})"
    message = (f"IPOPT: {st['return_status']} after {stats['iterations']} iterations, "
               f"cost {float(sol['f']):.10g}{where}.")
    result = OptimizationResult(traj, float(sol["f"]), success, st["return_status"], message, stats, x)
    if not success and throw:
        raise SolverError(message + " The last iterate is in `.result`.", result)
    return result


def _solver(problem, options):
    expand = _checks.boolean("options['expand']", options.pop("expand", False))
    merged = {**DEFAULT_IPOPT_OPTIONS, **options}
    opts = {"expand": expand, "print_time": False, "error_on_fail": False,
            **{"ipopt." + k: v for k, v in merged.items()}}
    try:
        return ca.nlpsol("dmoc", "ipopt", problem.nlp, opts)
    except RuntimeError as err:
        if "option" not in str(err).lower():
            raise
        raise ValueError(f"`options` were rejected by CasADi/IPOPT: {err}") from None


def most_violated(problem, g):
    """(largest bound violation, its description) over the constraint vector g."""
    violation = np.maximum(problem.lbg - g, g - problem.ubg)
    violation = np.where(np.isnan(violation), np.inf, np.maximum(violation, 0.0))
    if violation.size == 0:
        return 0.0, "none"
    i = int(np.argmax(violation))
    group, row, col = problem.g_layout.locate(i)
    if group == "dynamics":
        name = next(k for k, s in problem.residual.rows.items() if s.start <= row < s.stop)
        return float(violation[i]), f"dynamics at step {col} ({name} row {row - problem.residual.rows[name].start})"
    if group == "path":
        return float(violation[i]), f"path constraint {row} at step {col}"
    return float(violation[i]), f"boundary condition '{group}' row {row}"


def trajectory_from_x(problem, x):
    """The Trajectory held in an NLP vector x of `problem`."""
    lay, N = problem.x_layout, problem.steps
    h = float(lay.unpack(x, "h")[0, 0]) if problem.free_time else problem.disc.h
    mu = lay.unpack(x, "mu")[:, 0] if lay.numel("mu") else np.zeros(problem.disc.system.m)
    return Trajectory(h * np.arange(N + 1), lay.unpack(x, "q").T, lay.unpack(x, "p").T,
                      lay.unpack(x, "lam").T, lay.unpack(x, "u").T, h, problem.formulation.name,
                      mu, lay.unpack(x, "s").T, problem.disc.rule.control_nodes)


def initial_guess(problem, guess=None):
    """The NLP start vector from a Trajectory, or the default guess (see `optimize`)."""
    lay, N, sys = problem.x_layout, problem.steps, problem.disc.system
    x = np.zeros(lay.size)
    tau = np.linspace(0.0, 1.0, N + 1)
    h = problem.disc.h if guess is None else guess.h
    if problem.free_time:
        h = float(np.clip(h, *(T / N for T in problem.duration)))
    if guess is None:
        q = _default_path(problem, tau)
        v = np.gradient(q, h, axis=0)
        p = np.array(sys.momentum.map(N + 1)(q.T, v.T)).T
        blocks = {"q": q, "p": p, "s": problem.disc.rule.stage_guess(q, p)}
    else:
        _check_guess(problem, guess)
        blocks = _resampled(problem, guess, tau)
    blocks["v_start"] = np.nan_to_num(problem.v_start)[None, :]
    blocks["v_goal"] = np.nan_to_num(problem.v_goal)[None, :]
    if problem.free_time:
        blocks["h"] = np.array([[h]])
    for name, values in blocks.items():
        if values is not None and lay.numel(name):
            x[lay.slice(name)] = np.asarray(values, dtype=float).ravel()
    return np.clip(x, problem.lbx, problem.ubx)


def _check_guess(problem, guess):
    if guess.steps < 1:
        raise ValueError("`guess` must have at least one step; got a trajectory of 0 steps.")
    n, n_u = problem.disc.system.n, problem.disc.system.n_u
    if guess.q.shape[1] != n:
        raise ValueError(f"`guess` must have q with {n} columns for this problem; got {guess.q.shape[1]}.")
    if guess.u.shape[1] != n_u * len(guess.control_nodes):
        raise ValueError(f"`guess` must have u with {n_u} columns per control node for this "
                         f"problem; got {guess.u.shape[1]} for {len(guess.control_nodes)} nodes.")


def _default_path(problem, tau):
    start = np.where(np.isfinite(problem.q_start), problem.q_start, np.nan_to_num(problem.q_goal))
    goal = np.where(np.isfinite(problem.q_goal), problem.q_goal, start)
    bump = 0.1 * max(1.0, float(np.max(np.abs(goal - start))))
    return start + np.outer(tau, goal - start) + bump * np.sin(np.pi * tau)[:, None]


def _resampled(problem, guess, tau):
    """Guess blocks (time-major) on the problem's normalized grid tau, from a guess on any
    grid and with any rule: q, p interpolated at the knots, the controls evaluated by the
    guess's own interpolation (`Trajectory.control`) at the problem's control nodes, stages
    and multipliers kept where their layout matches, else stages on the chords."""
    disc, N = problem.disc, len(tau) - 1
    same_grid = guess.steps == N
    old = np.linspace(0.0, 1.0, guess.steps + 1)
    knots = {k: getattr(guess, k) if same_grid else
             np.column_stack([np.interp(tau, old, c) for c in getattr(guess, k).T]) for k in ("q", "p")}
    same_rule = (same_grid and guess.s.shape[1] == disc.n_stages
                 and guess.control_nodes == disc.rule.control_nodes)
    if same_rule:
        u = guess.u
    else:
        times = guess.t[0] + (guess.t[-1] - guess.t[0]) * (
            tau[:-1, None] + np.asarray(disc.rule.control_nodes)[None, :] / N)
        u = guess.control(times.ravel()).reshape(N, -1)
    lam = None
    if guess.lam.shape[1] == disc.n_multipliers:
        mid_new, mid_old = (tau[:-1] + tau[1:]) / 2, (old[:-1] + old[1:]) / 2
        lam = guess.lam if same_grid else np.column_stack(
            [np.interp(mid_new, mid_old, c) for c in guess.lam.T] or [np.zeros(N)])[:, :disc.n_multipliers]
    blocks = {**knots, "u": u, "lam": lam,
              "s": guess.s if same_rule else disc.rule.stage_guess(knots["q"], knots["p"])}
    if guess.mu.shape == (problem.x_layout.numel("mu"),):
        blocks["mu"] = guess.mu[None, :]
    return blocks
