"""The verdict's replay on the group through the NLP's own step: the controls of an optimum
replayed from its start by Newton's method on the step term's rows (the group step residual
and the group product, `dmoc.optimal_control.nlp.group_transcription`) with the Jacobian IPOPT
used (`separable.local_derivatives`, built by the solve), its square block of the left and
constraint rows in (f_k, lam_k), in CasADi's virtual machine; the simulator's stepper is
built only when a step of it does not converge."""

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
    the optimum's u_k: NEWTON_ITERATIONS Newton updates of (f_k, lam_k) on the left and
    constraint rows from the simulator's warm start (f_0 = h M(q_0)^{-1} p_0, 0 from rest
    without evaluating M, then the previous step's f and lam), q_{k+1} and p_{k+1} then
    explicit (the rows are linear in them with identity coefficients: the updates are
    those of Newton on the whole square system). Converged: every entry finite and the left and constraint rows' max-norm at
    most `tol` (1 + max(|p_k|, |p_{k+1}|)), the simulator's test of a step
    (`DiracStepper.accepted`; the other rows hold exactly). Not converged also when the
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
    y0 = np.zeros(p0.size + problem.disc.system.m)
    if p0.any():                    # at rest f_0 = 0, without M(q_0)
        y0[:p0.size] = h * np.linalg.solve(np.array(problem.disc.system.generalized_mass(q0)), p0)
    w = np.tile(T.p[step.p_index[:, 0]][:, None], (1, N))
    try:
        states, rows, scale = (np.array(v) for v in horizon(np.concatenate([q0, p0, y0]), traj.u.T, w))
    except RuntimeError:            # the linear solver refused a block (not finite)
        return None
    n_q = q0.size
    if not (np.isfinite(states).all() and np.isfinite(rows).all() and (rows <= tol * scale).all()):
        return None
    return Replay(np.vstack([q0, states[:n_q].T]), np.vstack([p0, states[n_q:n_q + p0.size].T]), N)


def _horizon(T, step, N):
    """The mapaccum over N steps of ``(state (q_k, p_k, f, lam), u_k, w) -> (state_{k+1},
    rows' max-norm, 1 + max(|p_k|, |p_{k+1}|))``. The term's rows are the residual's left,
    right and constraint rows and q_{k+1} - R_k cay(f) (`group_transcription`): the left
    and constraint rows read neither q_{k+1} nor p_{k+1}, the right rows hold p_{k+1} =
    D2 L_d + f_plus and the group rows q_{k+1} explicitly (identity coefficients), so
    Newton's updates of (f, lam) are those of the whole square system, solved on the
    (n + m) square block of the left and constraint rows (7 x 7 on the rolling ball, by
    a QR Linsol; the simulator's cofactors, `schur_complement.newton_update`, take longer
    to build), and q_{k+1}, p_{k+1} follow from the rows at q_{k+1} = p_{k+1} = 0. The
    update is an MX Function calling the local Jacobian's Function (rows and nonzeros in
    one call), not inlining it (the SX Functions that inline it took 0.5 ms more to
    build, 0.08 ms less to run 20 steps); the step, mapaccum'ed in the virtual machine,
    calls the update NEWTON_ITERATIONS times and the term's Function for the last rows
    (two MX Functions to build, no third one for the end). The group transcription has
    unit scales, so z holds x's entries as they are."""
    local = local_derivatives(step.function, step.function_key)
    layout, R = T.x_layout, T.dynamics_rows
    z = step.x_index[:, 0]
    block, row, col = zip(*(layout.locate(int(i)) for i in z))     # of z's entries
    n_q, n, m, n_u = (layout.unpack(np.arange(layout.size), b).shape[0] for b in ("q", "p", "lam", "u"))
    # V = (q_k, p_k, f, lam, u_k, 0): the entry of V that each entry of z reads (instance 0);
    # q_{k+1} and p_{k+1} read the 0
    offsets = {("q", 0): 0, ("p", 0): n_q, ("f", 0): n_q + n, ("lam", 0): n_q + 2 * n,
               ("u", 0): n_q + 2 * n + m}
    size = n_q + 2 * n + m + n_u
    source = [offsets[(b, c)] + r if (b, c) in offsets else size for b, r, c in zip(block, row, col)]
    rows = np.concatenate([np.arange(R.size)[R.slice("left")], np.arange(R.size)[R.slice("constraint")]])
    # z's entries of f, then lam: z reads each entry of V but the 0 once, so sorted by
    # source its first `size` entries are V's in order
    unknowns = np.argsort(source, kind="stable")[:size][n_q + n:n_q + 2 * n + m]
    jac_rows, jac_cols = local["jac_pattern"]
    pattern = ca.Sparsity.triplet(step.function.size1_out(1), z.size, jac_rows.tolist(), jac_cols.tolist())
    # MX symbols of (q_k, p_k), (f, lam), u_k and w; V = their column and a 0
    n_w = step.p_index.shape[0]
    S, Y, U, W = (ca.MX.sym(k, size_k) for k, size_k in (("s", n_q + n), ("y", n + m), ("u", n_u), ("w", n_w)))
    z_of = ca.vertcat(S, Y, U, ca.MX(1, 1))[source]
    g, values = local["jac"](z_of, W)
    block_jacobian = ca.MX(pattern, values)[rows.tolist(), unknowns.tolist()]
    solve = ca.Linsol("replay_solve", "qr", block_jacobian.sparsity())
    update = ca.Function("replay_update", [S, Y, U, W],
                         [Y - solve.solve(block_jacobian, g[rows.tolist()])])
    y = Y
    for _ in range(NEWTON_ITERATIONS):
        y = update(S, y, U, W)
    # the step's end at the last y, in the step's Function itself (no Function of its own)
    g = step.function(ca.vertcat(S, y, U, ca.MX(1, 1))[source], W)[1]
    p1 = g[R.slice("right")]
    state = ca.vertcat(S, Y)
    one = ca.Function("replay_step", [state, U, W],
                      [ca.vertcat(-g[R.size:], p1, y), ca.norm_inf(g[rows.tolist()]),
                       1 + ca.fmax(ca.norm_inf(S[n_q:]), ca.norm_inf(p1))])
    return one.mapaccum("replay", N)
