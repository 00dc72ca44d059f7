"""Initial guesses of the DMOC NLP (consumer 2, solver half): the default guess, a
Trajectory from any grid and rule resampled onto the problem's, or an optimum of the same
problem structure taken as it is (primal and dual, for IPOPT's warm start).
"""

import numpy as np

from ...principle.trajectory import Trajectory
from ...errors import InputError
from .fixed_multipliers import fixed_entries, ipopt_start
from ..nlp.scaling import lengths


def start_point(problem, guess, fixed=None):
    """(x0, lam_x0, lam_g0) for IPOPT from `guess`: None, a Trajectory, or an
    OptimizationResult. A result of a problem with the same NLP structure
    (``result.structure == problem.structure``) is taken as it is, its configurations
    re-centered on this problem's q_ref, its x clipped into the new bounds (new boundary
    data) and its multipliers kept (lam_x as `fixed_multipliers.ipopt_start` gives it for
    problem's fixed entries `fixed`, by default `fixed_entries`); any other guess gives its
    trajectory, resampled, and zero multipliers (a cold start)."""
    T = problem.transcription
    if guess is None or isinstance(guess, Trajectory):
        return (initial_guess(problem, guess),) + _cold(T)
    if guess.structure == T.structure and guess.lam_g is not None and guess.q_ref is not None:
        x = np.array(guess.x, dtype=float)
        x[T.x_layout.slice("q")].reshape(problem.steps + 1, -1)[:] += guess.q_ref - T.q_ref    # each knot
        fixed = fixed_entries(T.lbx / T.x_scale, T.ubx / T.x_scale) if fixed is None else fixed
        return np.clip(x, T.lbx, T.ubx), ipopt_start(guess, fixed), guess.lam_g
    return (initial_guess(problem, guess.trajectory),) + _cold(T)


def _cold(transcription):
    """The multipliers of a cold start: (lam_x, lam_g) zero."""
    return np.zeros(transcription.lbx.size), np.zeros(transcription.lbg.size)


def initial_guess(problem, guess=None):
    """The NLP start vector from a Trajectory, or the default guess (see `optimize`)."""
    T, N, sys = problem.transcription, problem.steps, problem.disc.system
    lay = T.x_layout
    x = np.zeros(lay.size)
    tau = np.linspace(0.0, 1.0, N + 1)
    # the step within the final time's range (h itself when fixed); x has no "h" then
    h = float(np.clip(problem.disc.h if guess is None else guess.h, *problem.final_time.step_range(N)))
    if guess is None:
        q = _default_path(problem, tau, h)
        v = np.gradient(q, h, axis=0)
        p = np.array(sys.momentum.map(N + 1)(q.T, v.T)).T
        blocks = {"q": q, "p": p, "s": problem.disc.rule.stage_guess(q, p)}
    else:
        _check_guess(problem, guess)
        blocks = _resampled(problem, guess, tau)
    blocks["v_start"] = np.nan_to_num(problem.v_start)[None, :]
    blocks["v_goal"] = np.nan_to_num(problem.v_goal)[None, :]
    blocks["h"] = np.array([[h]])
    blocks["q"] = blocks["q"] - T.q_ref               # the NLP holds q - q_ref
    for name, values in blocks.items():      # time-major values; a block of fewer columns
        if values is not None and lay.numel(name):     # (p_0 of substituted momenta) takes the first
            x[lay.slice(name)] = np.asarray(values, dtype=float)[:lay.blocks[name][2]].ravel()
    return np.clip(x, T.lbx, T.ubx)


def _check_guess(problem, guess):
    if guess.steps < 1:
        raise InputError("`guess` must have at least one step; got a trajectory of 0 steps.")
    n, n_u = problem.disc.system.n, problem.disc.system.n_u
    if guess.q.shape[1] != n:
        raise InputError(f"`guess` must have q with {n} columns for this problem; got {guess.q.shape[1]}.")
    if guess.u.shape[1] != n_u * len(guess.control_nodes):
        raise InputError(f"`guess` must have u with {n_u} columns per control node for this "
                         f"problem; got {guess.u.shape[1]} for {len(guess.control_nodes)} nodes.")


def _default_path(problem, tau, h):
    """Configurations (N+1, n) on the chord from the start to the goal bent by 0.1 l_i
    sin(pi tau), l the coordinates' lengths in the motion (`scaling.lengths`): a bump in
    the units of each coordinate, the same path whatever the units of length and mass.
    A free goal entry is where the given start velocity carries its start over the guess's
    duration N h (held at q_ref without one): a car started at 10 m/s towards a free goal
    x is guessed driving on, not standing while the other coordinates move (the lane
    change's midpoint solve from x held at 0 ended `Infeasible_Problem_Detected` from
    N = 90 on)."""
    start = problem.transcription.q_ref        # the given start, else goal, entries
    drift = np.nan_to_num(problem.v_start) * h * (len(tau) - 1)
    goal = np.where(np.isfinite(problem.q_goal), problem.q_goal, start + drift)
    bump = 0.1 * lengths(problem.disc.system, start, problem.q_goal - problem.q_start)
    return start + np.outer(tau, goal - start) + np.outer(np.sin(np.pi * tau), bump)


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
    if guess.mu.shape == (problem.transcription.x_layout.numel("mu"),):
        blocks["mu"] = guess.mu[None, :]
    return blocks
