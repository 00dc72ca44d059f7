"""The light verdict's figures in one compiled evaluation (a driver, issue 41): the replay
of every step from its knot (`dmoc.drivers.step_replay`), the departures from the next
knot, the velocity jumps of the rule's interpolant, the velocity bounds and the path
constraints at the knots and between them, as one CasADi Function of an optimum's stacked
arrays per structure and N, compiled to C in the background (`dmoc._util.compiled`) and
returning every figure `dmoc.drivers.verdict.light_judge` reads, with the knot and the
row of each maximum (docs/verification.md, "The light verdict of a re-solve").

Its figures are those of `dmoc.results.figure_rules`, which the NumPy path evaluates on
arrays (`step_replay.step_departure`, `dmoc.results.knot_velocities.velocity_changes`,
`dmoc.drivers.knot_checks`, `dmoc.drivers.verdict_checks`) and this Function on SX: one
statement, the same operations, so the Verdict is the same; the arguments (the steps'
start states, the knot velocities, the path rows between the knots,
`dmoc.drivers.interpolant_path`) are assembled here. While the library is not loaded, or
where a value it reads is not finite, the NumPy path judges.
"""

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from .._util.compiled import Background, Library, compiler
from .._util.numeric import Evaluator
from ..discrete.knot_states import end_velocity_function
from ..discrete.rules import lagrange_basis
from ..simulation.stepper import DiracStepper
from ..results import figure_rules
from ..results.figure_rules import SYMBOLIC
from .interpolant_path import BETWEEN_KNOTS
from .verdict_checks import REPLAY_TOLERANCE, REST_TOLERANCE

# keyed by the structure and N (`_key`): its `_Figures`, which keeps the objects whose ids
# are in the key
_FIGURES = BoundedCache(16, "verdict_figures")
# the figures' entries, in the order of the Function's one output
FIELDS = ("accepted", "finite", "replay_q", "replay_p", "replay_step", "jump", "jump_step",
          "jump_coordinate", "path", "path_step", "path_row", "cut", "cut_point", "cut_row")
# the endings of the fields that hold indices
INDICES = ("_step", "_coordinate", "_row", "_point")


def figures(problem, traj, step):
    """{field of `FIELDS`: value} of the optimum `traj` of `problem` by the compiled
    evaluation (the module notes), `step` the verdict's replay stepper
    (`step_replay._CompiledStep`); None while its library is not loaded (the first call
    starts compiling or loading it in the background; never without a C compiler).

    ``accepted``: the fast path accepted every step (`DiracStepper.accepted`);
    ``finite``: every value the figures are read from is finite; ``replay_step``: the first knot k = 1 ... N whose
    step departs beyond REPLAY_TOLERANCE, or -1; ``jump``, ``jump_step``,
    ``jump_coordinate``: the largest velocity change, its knot and the index of its
    coordinate (0, 0, 0 for N < 2: `largest_change`); ``path``, ``path_step``,
    ``path_row``: the largest relative value of the knot rows (path constraints, then the
    velocity bounds), its knot and row, (0, -1, -1) where none exceeds 0
    (`path_violation`); ``cut``, ``cut_point``, ``cut_row``: the same of the path rows
    between the knots, the point j of step k counted k len(BETWEEN_KNOTS) + j. Indices are
    floats holding integers.
    """
    entry = _FIGURES.get(_key(problem, traj), lambda: _Figures(problem, traj, step))
    evaluate = entry.evaluator()
    if evaluate is None:
        return None
    arrays = [traj.q.ravel(), traj.p.ravel(), traj.lam.ravel(), traj.s.ravel(), traj.u.ravel(),
              [traj.h], entry.data(problem)]
    (out,) = evaluate(np.concatenate(arrays))
    return dict(zip(FIELDS, out.ravel().tolist()))


def _key(problem, traj):
    """What the Function depends on besides the optimum's values: the discretization (its
    system, rule and residual), the variant, the shapes, the path constraints and the
    parameters' schedule, which velocity bounds are finite."""
    schedule = problem.parameters.schedule
    return (id(problem.disc), traj.variant, traj.q.shape, traj.lam.shape[1], traj.s.shape[1],
            traj.u.shape[1], tuple(traj.control_nodes), id(problem.path_constraints), id(schedule),
            *(tuple(np.isfinite(b)) for b in problem.velocity_bounds))


class _Figures:
    """The figures' Function of one structure and N, built and compiled (or loaded from the
    cache folder) in the background."""

    def __init__(self, problem, traj, step):
        self.kept = (problem.disc, problem.path_constraints, problem.parameters.schedule)
        self.finite = [np.isfinite(b) for b in problem.velocity_bounds]
        shapes = dict(N=traj.steps, n=traj.q.shape[1], m=traj.lam.shape[1], ns=traj.s.shape[1],
                      nu=traj.u.shape[1], control_nodes=tuple(traj.control_nodes),
                      stage_nodes=tuple(traj.stage_nodes))
        stepper, rule, paths = step.stepper, problem.disc.rule, problem.path_constraints
        at, size = problem.parameters.schedule.point_function(), problem.parameters.knot_values().shape[0]

        def load():
            fast = DiracStepper(stepper.residual, stepper.tol, stepper.max_iter, native=None).fast
            built = _function(fast, stepper, rule, paths, at, size, self.finite, **shapes)
            return Library([built], "verdict_figures").load()
        self.loading = None if compiler() is None else Background(load)
        self._evaluator = None

    def evaluator(self):
        """The Evaluator of the loaded Function, or None while it is not loaded."""
        if self._evaluator is None and self.loading is not None and self.loading.functions:
            self._evaluator = Evaluator(self.loading.functions["verdict_figures"])
        return self._evaluator

    def data(self, problem):
        """The problem's values the figures read: the finite velocity bounds (lower, then
        upper), the rest threshold of each coordinate, the parameters' step vectors at the
        knots (with path constraints)."""
        T = problem.transcription
        rest = REST_TOLERANCE * T.x_layout.unpack(T.x_scale, "q")[:, 0]
        parts = [b[f] for b, f in zip(problem.velocity_bounds, self.finite)] + [rest]
        if problem.path_constraints is not None:
            parts.append(problem.parameters.knot_values().ravel(order="F"))
        return np.concatenate(parts)


def _function(fast, stepper, rule, paths, at, size, finite, *, N, n, m, ns, nu, control_nodes,
              stage_nodes):
    """The Function ``z -> figures`` (`figures`), z the optimum's q, p, lam, s, u (each
    time-major, flat), h and the problem's data (`_Figures.data`)."""
    nb = [int(f.sum()) for f in finite]
    counts = [(N + 1) * n, (N + 1) * n, N * m, N * ns, N * nu, 1,
              sum(nb) + n + (0 if paths is None else size * (N + 1))]
    z = ca.MX.sym("z", sum(counts))
    q, p, lam, s, u, h, data = ca.vertsplit(z, np.cumsum([0, *counts]).tolist())
    Q, P, L, S, U = (ca.reshape(x, -1, cols)
                     for x, cols in ((q, N + 1), (p, N + 1), (lam, N), (s, N), (u, N)))
    following, out = fast.map(N)(_states(stepper, Q, P, L, S, n, N), U, ca.repmat(h, 1, N))
    start, end = end_velocity_function(rule, n, ns).map(N)(Q[:, :N], Q[:, 1:], S, ca.repmat(h, 1, N))
    V = ca.horzcat(start[:, 0], (end[:, :N - 1] + start[:, 1:]) / 2, end[:, N - 1])
    lower, upper, rest, w = ca.vertsplit(data, np.cumsum([0, *nb, n, data.numel() - sum(nb) - n]).tolist())
    knots = figure_rules.bound_rows(SYMBOLIC, V.T, *((np.flatnonzero(f), b) for f, b in zip(finite, (lower, upper)))).T
    cut = ca.MX(0, N * len(BETWEEN_KNOTS))
    if paths is not None:
        W = ca.reshape(w, size, N + 1)
        g_knots, cut = _path_rows(paths, at, Q, S, U, V, W, h, n, N, control_nodes, stage_nodes)
        knots = ca.vertcat(g_knots, knots)
    follow = {name: following[stepper.state.slice(name), :] for name in ("q", "p")}
    figures = _figure_function(stepper, n, N, knots.shape[0], cut.shape[0], out.shape[0],
                               paths is not None)
    return ca.Function("verdict_figures", [z], [figures(Q, P, follow["q"], follow["p"], out, start,
                                                        end, rest, knots, cut)], ["z"], ["figures"])


def _states(stepper, Q, P, L, S, n, N):
    """The replay's start state at every knot k < N (`step_replay.step_departure`): q_k,
    p_k and step k - 1 (zero increments at k = 0), as columns."""
    blocks = dict(q=Q[:, :N], p=P[:, :N], dq=Q[:, 1:N] - Q[:, :N - 1], nu=L[:, :N - 1],
                  ds=S[:, :N - 1] - ca.repmat(Q[:, :N - 1], S.shape[0] // n, 1))
    rows = []
    for name in stepper.state.blocks:
        x = blocks[name]
        rows.append(x if name in ("q", "p") else ca.horzcat(ca.MX(x.shape[0], 1), x))
    return ca.densify(ca.vertcat(*rows))


def _path_rows(paths, at, Q, S, U, V, W, h, n, N, control_nodes, stage_nodes):
    """The path constraints at the knots (q_k, v_k, u(t_k), w at q_k) and at
    `BETWEEN_KNOTS` of every step on the rule's interpolant (`dmoc.principle.dense`), rows
    by points."""
    blocks = len(control_nodes)
    u_knots = ca.horzcat(_combination(lagrange_basis(control_nodes, 0.0)[0], U, blocks),
                         _combination(lagrange_basis(control_nodes, 1.0)[0], U[:, N - 1], blocks))
    w_knots = W if at is None else at.map(N + 1)(W, 0.0, h)
    g_knots = paths.map(N + 1)(Q, V, u_knots, w_knots)
    nodes = (0.0, *stage_nodes, 1.0)
    first = S.shape[0] - len(stage_nodes) * n       # the stage configurations: the last rows
    values = [Q[:, :N], *(S[first + j * n:first + (j + 1) * n, :] for j in range(len(stage_nodes))), Q[:, 1:]]
    qs, vs, us, ws = [], [], [], []
    for c in BETWEEN_KNOTS:
        basis, slope = lagrange_basis(nodes, c)
        qs.append(_sum(basis, values))
        vs.append(_sum(slope, values) / h)
        us.append(_combination(lagrange_basis(control_nodes, c)[0], U, blocks))
        ws.append(W[:, :N] if at is None else at.map(N)(W[:, :N], c, h))
    K = len(BETWEEN_KNOTS)
    points = [ca.reshape(ca.vertcat(*x), -1, N * K) for x in (qs, vs, us, ws)]
    return g_knots, paths.map(N * K)(*points)


def _sum(coefficients, terms):
    """sum_j a_j x_j from 0 term by term, as NumPy's einsum adds them."""
    total = 0.0 * terms[0]
    for a, x in zip(coefficients, terms):
        total = total + float(a) * x
    return total


def _combination(basis, U, blocks):
    """The control at a step time from the step's values at the control nodes (rows of U
    block by block), `dmoc.principle.dense.controls`."""
    rows = U.shape[0] // blocks
    return _sum(basis, [U[j * rows:(j + 1) * rows, :] for j in range(blocks)])


def _figure_function(stepper, n, N, rows, cut_rows, out_rows, paths):
    """The SX Function of the figures from the arrays of `_function` (one column per knot,
    step or point): ``accepted``, ``finite`` (of every value the figures are read from)
    and the figures of `FIELDS` after them, each as `dmoc.results.figure_rules` states it
    (time-major: the columns transposed)."""
    sym = ca.SX.sym
    Q, P, Fq, Fp = sym("Q", n, N + 1), sym("P", n, N + 1), sym("Fq", n, N), sym("Fp", n, N)
    out, start, end, rest = sym("out", out_rows, N), sym("start", n, N), sym("end", n, N), sym("rest", n)
    knots, cut = sym("knots", rows, N + 1), sym("cut", cut_rows, N * len(BETWEEN_KNOTS))
    at = {name: stepper.out.slice(name).start for name in ("rnorm", "update", "scale", "nonfinite")}
    accepted = 1
    for k in range(N):          # `DiracStepper.accepted`
        accepted = ca.logic_and(accepted, ca.logic_and(ca.logic_and(
            out[at["nonfinite"], k] == 0, out[at["update"], k] <= 1e-6),
            out[at["rnorm"], k] <= 1e3 * stepper.tol * out[at["scale"], k]))
    each, replay = _replay(Q.T, P.T, Fq.T, Fp.T)
    changes = figure_rules.still(SYMBOLIC, figure_rules.relative_changes(SYMBOLIC, start.T, end.T), Q.T, rest.T)
    largest, k, i = figure_rules.largest_entry(SYMBOLIC, changes)
    jump = (largest, k + 1, i) if changes.shape[0] else (largest, k, i)
    path = figure_rules.violation(SYMBOLIC, knots.T)
    # the path rows between the knots against the scale of all points (`interpolant_path_values`)
    cut_value = figure_rules.violation(SYMBOLIC, ca.vertcat(knots[:cut_rows, :].T, cut.T), N + 1) \
        if paths and cut_rows else (0.0, -1.0, -1.0)
    figures = [*replay, *jump, *path, *cut_value]
    read = ca.vertcat(*figures, each, ca.vec(changes), ca.vec(knots), ca.vec(cut))
    finite = ca.sum1(1 - (ca.fabs(read) < ca.inf)) == 0
    return ca.Function("figures", [Q, P, Fq, Fp, out, start, end, rest, knots, cut],
                       [ca.vertcat(accepted, finite, *figures)])


def _replay(Q, P, Fq, Fp):
    """(each step's departure, (replay_q, replay_p, replay_step)) of the steps landing at
    `Fq`, `Fp` (N, n) from the optimum's knots `Q`, `P` (N + 1, n)
    (`step_replay.step_departure`)."""
    dq = figure_rules.departures(SYMBOLIC, Fq, Q[1:, :], figure_rules.q_scale(SYMBOLIC, Q))
    dp = figure_rules.departures(SYMBOLIC, Fp, P[1:, :], figure_rules.scale(SYMBOLIC, SYMBOLIC.largest(abs(P))))
    each = SYMBOLIC.maximum(dq, dp)
    first = figure_rules.first_beyond(SYMBOLIC, each, REPLAY_TOLERANCE)
    return each, (SYMBOLIC.largest(dq), SYMBOLIC.largest(dp), ca.if_else(first < 0, -1, first + 1))
