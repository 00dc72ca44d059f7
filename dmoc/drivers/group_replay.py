"""The verdict's replay on the group through the NLP's own step: the controls of an optimum
replayed from its start by Newton's method on the step term's rows (the group step residual
and the group product, `dmoc.optimal_control.nlp.group_transcription`) with the Jacobian IPOPT
used (`separable.local_derivatives`, built by the solve), in CasADi's virtual machine; the
simulator's stepper is built only when a step of it does not converge."""

from collections import namedtuple

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from ..optimal_control.nlp.group_transcription import group_transcription
from ..optimal_control.nlp.separable import local_derivatives

NEWTON_ITERATIONS = 4       # from the previous step's increment: converged in 3 on the rolling ball

Replay = namedtuple("Replay", "q p steps")
_HORIZONS = BoundedCache(8, "group_replays")     # keyed by (step term's key, N)


def nlp_replay(problem, traj, tol=1e-12, transcription=None):
    """The replay of the optimum `traj` of `problem` (a GroupOptimalControlProblem) by the
    NLP's step rows, or None when a step did not converge.

    Step k solves the 2n + m rows of the residual and the 9 + n_x rows q_{k+1} - (R_k
    cay(f_k), x_k + dx_k) for (q_{k+1}, p_{k+1}, f_k, lam_k) at the replayed (q_k, p_k) and
    the optimum's u_k: NEWTON_ITERATIONS Newton updates from the simulator's warm start
    (f_0 = h M(q_0)^{-1} p_0, then the previous step's f and lam; the rows are linear in
    q_{k+1} and p_{k+1}, which the first update makes exact for its f). Converged: every
    entry finite and the rows' max-norm at most `tol` (1 + max(|p_k|, |p_{k+1}|)), the
    simulator's test of a step (`DiracStepper.accepted`). Not converged also when the
    virtual machine's linear solver refuses an update (entries not finite). `transcription`
    is `problem`'s `group_transcription` when the caller holds it (the solve's), else built.

    Returns
    -------
    Replay or None
        ``q`` (N + 1, 9 + n_x), ``p`` (N + 1, n), ``steps`` N: what
        `verdict_checks.replay_departure` compares.
    """
    T = group_transcription(problem) if transcription is None else transcription
    step = T.separable.terms[0]             # group_transcription's first term: the step
    N, h = problem.steps, problem.disc.h
    horizon = _HORIZONS.get((step.function_key, N), lambda: _horizon(T, step, N))
    q0, p0 = traj.q[0], traj.p[0]
    mass = np.array(problem.disc.system.generalized_mass(q0))
    y0 = np.concatenate([h * np.linalg.solve(mass, p0), np.zeros(problem.disc.system.m)])
    w = np.tile(T.p[step.p_index[:, 0]][:, None], (1, N))
    try:
        states, rows, scale = (np.array(v) for v in horizon(np.concatenate([q0, p0, y0]), traj.u.T, w))
    except RuntimeError:            # the linear solver refused a Jacobian (not finite)
        return None
    n_q = q0.size
    if not (np.isfinite(states).all() and np.isfinite(rows).all() and (rows <= tol * scale).all()):
        return None
    return Replay(np.vstack([q0, states[:n_q].T]), np.vstack([p0, states[n_q:n_q + p0.size].T]), N)


def _horizon(T, step, N):
    """The mapaccum over N steps of ``(state (q_k, p_k, f, lam), u_k, w) -> (state_{k+1},
    rows' max-norm, 1 + max(|p_k|, |p_{k+1}|))``: the step term's Function and its local
    Jacobian called on z = V[perm], V = (q1, p1, f, lam, q0, p0, u) (the group transcription
    has unit scales, so z holds x's entries as they are)."""
    local = local_derivatives(step.function, step.function_key)
    layout = T.x_layout
    block, row, col = _labels(layout)
    z = step.x_index[:, 0]
    n_q, n, m, n_u = (layout.unpack(np.arange(layout.size), b).shape[0] for b in ("q", "p", "lam", "u"))
    offsets = {("q", 1): 0, ("p", 1): n_q, ("f", 0): n_q + n, ("lam", 0): n_q + 2 * n,
               ("q", 0): n_q + 2 * n + m, ("p", 0): 2 * n_q + 2 * n + m, ("u", 0): 2 * n_q + 3 * n + m}
    perm = [offsets[(block[i], col[i])] + row[i] for i in z]      # instance 0: q_0, q_1, ... f_0
    unknowns = n_q + 2 * n + m
    position = np.full(unknowns + n_q + n + n_u, -1)
    position[perm] = np.arange(len(perm))
    rows_and_jacobian = _rows_and_jacobian(step, local, position[:unknowns])
    solve = ca.Linsol("replay_solve", "qr", rows_and_jacobian.sparsity_out(1))
    state, u = ca.MX.sym("state", n_q + 2 * n + m), ca.MX.sym("u", n_u)
    w = ca.MX.sym("w", step.p_index.shape[0])
    q0, p0, y = ca.vertsplit(state, [0, n_q, n_q + n, state.numel()])
    Y = ca.vertcat(q0, p0, y)           # q1, p1 from q0, p0
    for _ in range(NEWTON_ITERATIONS):
        g, J = rows_and_jacobian(ca.vertcat(Y, q0, p0, u)[perm], w)
        Y = Y - solve.solve(J, g)
    g = rows_and_jacobian(ca.vertcat(Y, q0, p0, u)[perm], w)[0]
    q1, p1, y1 = ca.vertsplit(Y, [0, n_q, n_q + n, unknowns])
    one = ca.Function("replay_step", [state, u, w],
                      [ca.vertcat(q1, p1, y1), ca.norm_inf(g),
                       1 + ca.fmax(ca.norm_inf(p0), ca.norm_inf(p1))])
    return one.mapaccum("replay", N)


def _rows_and_jacobian(step, local, columns):
    """SX Function ``(z, w) -> (g, dg/d unknowns)`` of the step term: its rows and the
    columns `columns` of its local Jacobian (the unknowns' entries of z, in their order)."""
    z, w = step.function.sx_in()
    rows, cols = local["jac_pattern"]
    g, values = local["jac"](z, w)          # the rows and their Jacobian's nonzeros, one call
    jacobian = ca.SX(ca.Sparsity.triplet(step.function.size1_out(1), z.numel(), rows.tolist(),
                                         cols.tolist()), values)
    return ca.Function("replay_rows", [z, w], [g, jacobian[:, columns.tolist()]])


def _labels(layout):
    """(block, row, column) of every entry of x, arrays of the layout's size."""
    block, row, col = np.empty(layout.size, object), np.zeros(layout.size, int), np.zeros(layout.size, int)
    for name in layout.blocks:
        index = layout.unpack(np.arange(layout.size), name)
        if not index.size:
            continue
        index = index.reshape(index.shape[0], -1)
        block[index] = name
        row[index] = np.arange(index.shape[0])[:, None]
        col[index] = np.arange(index.shape[1])[None, :]
    return block, row, col
