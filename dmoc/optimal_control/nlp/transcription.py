"""The DMOC transcription of an OptimalControlProblem (consumer 2 of the step residual): the
nonlinear program (Ober-Bloebaum, Junge & Marsden 2011) whose dynamic constraints are the
step residual of (37)/(41) at every step, with its named layouts of x, p and g, its
scaling by the inertia (`dmoc.optimal_control.nlp.scaling`), its terms (`dmoc.optimal_control.nlp.terms`,
`dmoc.optimal_control.nlp.separable`) and its bounds and parameter values. The problem is the user's
statement; this object is everything built from it for the solver.
"""

import numpy as np

from ..._util.layout import Layout
from ..statement.parameters import refuse_violated_ends
from .control_hull import hull_bounds, hull_matrix, hulled_controls
from .path_terms import row_counts
from ..statement.read_only import ReadOnly, frozen
from .scaling import nlp_scales
from .terms import transcribe


class Transcription(ReadOnly):
    """The NLP ``min f(x, p) s.t. lbg <= g(x, p) <= ubg, lbx <= x <= ubx`` of a problem.

    Parameters
    ----------
    problem : OptimalControlProblem
        The statement it transcribes (read once; the transcription keeps no reference).

    Attributes
    ----------
    nlp : dict
        ``{"x", "p", "f", "g"}`` CasADi MX expressions, for ``casadi.nlpsol`` (pass
        ``p=transcription.p``). Its x is the scaled vector x / `x_scale` and its g the
        scaled rows `g_scale` * g: pass ``x0 / x_scale``, ``lbx / x_scale``,
        ``ubx / x_scale``, ``lbg * g_scale``, ``ubg * g_scale`` and multiply the solution
        by `x_scale`.
    separable : SeparableNLP
        The same NLP as terms, with its assembled exact derivatives
        (``separable.derivatives()``, the ``cache`` option of ``casadi.nlpsol``).
    x_layout, p_layout, g_layout : Layout
        Named blocks of x (``q, p, lam, s, u, v_start, v_goal, mu, nu, h``; ``p`` holds p_0
        alone when the momenta are substituted, see `momenta`; ``v_start`` is fixed at 0
        when the start is a momentum), of p (``h, q_ref, w, p_start``; ``p_start`` empty
        unless the problem gives it) and
        of g (``dynamics`` (rows of `dynamics_rows`, N), ``start``, ``goal``,
        ``start_velocity``, ``goal_velocity``, ``path`` (points * rows, N) at the steps'
        interior points, ``path_knots`` (rows, N+1) at q_0 ... q_N, ``velocity_steps`` (points * bounded,
        N) at the steps' interior points, ``velocity_knots`` (bounded, N+1, stage rules
        only) at q_0 ... q_N: `dmoc.optimal_control.nlp.path_terms`; ``control_hull``
        ((d - 1) * hulled, N): the interior Bernstein coefficients of the bounded
        controls' interpolants, `dmoc.optimal_control.nlp.control_hull`).
    velocity_bounded : tuple of int
        The entries of v with a finite velocity bound, those of the velocity rows (in
        their order).
    hulled_controls : tuple of int
        The controls with a finite bound whose interpolant is bounded between the nodes
        (rules with 3 or more control nodes; else empty).
    dynamics_rows : Layout
        The residual rows imposed at each step (all of R, or all but "right").
    x_scale, g_scale : ndarray, shapes (x_layout.size,) and (g_layout.size,)
        The scaling by the system's inertia at `q_ref` (`dmoc.optimal_control.nlp.scaling`).
    lbx, ubx, lbg, ubg : ndarray
        Bounds of x and g (read-only arrays).
    scaled_g_bounds : tuple of ndarray
        (``lbg * g_scale``, ``ubg * g_scale``), shapes (g_layout.size,): the bounds of the
        scaled rows IPOPT imposes, made once per NLP (shared by `with_bounds`).
    p : ndarray, shape (p_layout.size,)
        The values of the parameter vector: the step h (fixed final time), q_ref, the
        stacked parameter values (block ``w``) and the start momentum (block ``p_start``).
    q_ref : ndarray, shape (n,)
        The configuration the NLP is centered on: block "q" of x holds q_k - q_ref (the
        given entries of q_start, else of q_goal, else 0), so that IPOPT's steps and
        tolerances follow the size of the motion, not of the coordinates.
    structure : str
        A key of the NLP by value (`SeparableNLP.key`).
    """

    _CHANGE_ANY = ("it is built from its problem; change the problem (`with_boundary`, "
                   "`with_parameters`) or build a new OptimalControlProblem")

    def __init__(self, problem):
        sys, disc, N = problem.disc.system, problem.disc, problem.steps
        n = sys.n
        m_start, m_end = problem.formulation.momentum_conditions(sys)[2:]
        rows = {e: sys.m if imposed else 0 for e, imposed in problem.velocity_rows.items()}
        path = problem.path_constraints
        self._velocity_bounded = tuple(problem.velocity_bounded)
        count = row_counts(disc.rule, path.numel_out(0) if path else 0, len(self._velocity_bounded))
        self._hulled = tuple(hulled_controls(problem.control_bounds, disc.rule.control_nodes))
        self._dynamics_rows = problem.momentum_treatment.dynamics_rows
        self._x_layout = Layout([("q", (n, N + 1)), ("p", (n, problem.momentum_treatment.columns(N))),
                                 ("lam", (disc.n_multipliers, N)), ("s", (disc.n_stages, N)),
                                 ("u", (disc.n_controls, N)), ("v_start", (n, 1)), ("v_goal", (n, 1)),
                                 ("mu", (m_start, 1)), ("nu", (m_end, 1)),
                                 ("h", (problem.final_time.x_entries, 1))])
        self._p_layout = Layout([("h", (problem.final_time.p_values.size, 1)), ("q_ref", (n, 1)),
                                 ("w", (problem.parameters.schedule.size, 1)),
                                 ("p_start", (0 if problem.p_start is None else n, 1))])
        self._g_layout = Layout([("dynamics", (self._dynamics_rows.size, N)), ("start", (n, 1)),
                                 ("goal", (n, 1)), ("start_velocity", (rows["start"], 1)),
                                 ("goal_velocity", (rows["goal"], 1)),
                                 ("path", (count["path"], N)), ("path_knots", (count["path_knots"], N + 1)),
                                 ("velocity_steps", (count["velocity_steps"], N)),
                                 ("velocity_knots", (count["velocity_knots"], N + 1)),
                                 ("control_hull", (hull_matrix(disc.rule.control_nodes).shape[0]
                                                   * len(self._hulled), N))])
        q_ref = reference(problem.q_start, problem.q_goal)
        self._x_scale, self._g_scale = (frozen(s) for s in nlp_scales(
            disc, problem.formulation, (self._x_layout, self._g_layout), self._dynamics_rows, q_ref,
            problem.q_goal - problem.q_start, self._hulled))
        self._separable, self._momenta = transcribe(
            problem, (self._x_layout, self._p_layout, self._g_layout), (self._x_scale, self._g_scale))
        self._nlp = {k: getattr(self._separable, k) for k in ("x", "p", "f", "g")}
        self._end_checks = {}       # `refuse_violated_ends`' checks, shared with `with_bounds`
        q, v_start, v_goal = (self._x_layout.slice(name) for name in ("q", "v_start", "v_goal"))
        # the entries of x the boundary data fix: q_0 and q_N (column 0 and N of block q),
        # v_start, v_goal (in the order `_set_boundary_bounds` stacks the data)
        self._data_entries = frozen(np.concatenate([q.start + np.arange(n), q.start + N * n + np.arange(n),
                                                     v_start.start + np.arange(n), v_goal.start + np.arange(n)]))
        self._set_bounds(problem)

    def with_bounds(self, problem):
        """This transcription with the bounds and parameter values of `problem`, which must
        have the same NLP (new boundary data with the same velocity rows, or new parameter
        values): the layouts, scales and terms are shared, and so are the bounds that do
        not read boundary data (of u, h and g) and, while q_ref keeps its bits, the state
        bounds of block q."""
        new = object.__new__(Transcription)
        new.__dict__.update(self.__dict__)
        new._set_boundary_bounds(problem)
        return new

    def _set_bounds(self, problem):
        lay = self._x_layout
        lbx, ubx = np.full(lay.size, -np.inf), np.full(lay.size, np.inf)
        step_range = problem.final_time.step_range(problem.steps)
        for bound, side in ((lbx, 0), (ubx, 1)):
            lay.unpack(bound, "u")[:] = np.tile(problem.control_bounds[side],
                                                len(problem.disc.rule.control_nodes))[:, None]
            lay.unpack(bound, "h")[:] = step_range[side]
            for end in ("v_start", "v_goal"):       # free boundary velocities in the box
                lay.unpack(bound, end)[:] = problem.velocity_bounds[side][:, None]
        lbg, ubg = np.zeros(self._g_layout.size), np.zeros(self._g_layout.size)
        for name in ("path", "path_knots"):
            lbg[self._g_layout.slice(name)] = -np.inf
        for bound, hull in zip((lbg, ubg), hull_bounds(problem.control_bounds,
                                                       problem.disc.rule.control_nodes)):
            self._g_layout.unpack(bound, "control_hull")[:] = hull[:, None]
        for name in ("velocity_steps", "velocity_knots"):
            for bound, side in ((lbg, 0), (ubg, 1)):
                block = self._g_layout.unpack(bound, name)
                block[:] = np.resize(problem.velocity_bounds[side][list(self._velocity_bounded)],
                                     block.shape[0])[:, None]
        self._lbg, self._ubg = frozen(lbg), frozen(ubg)
        self._scaled_g_bounds = (frozen(lbg * self._g_scale), frozen(ubg * self._g_scale))
        self._open_bounds = (lbx, ubx)
        self._set_boundary_bounds(problem)

    def _set_boundary_bounds(self, problem):
        """q_ref, p, `lbx` and `ubx` from `problem`'s data: the open bounds (those of u and
        h, of block q the state bounds, of v_start and v_goal the velocity bounds, infinite
        elsewhere) with the given boundary data
        fixed; the path constraints checked at the given ends. The open bounds are formed
        again only when q_ref changes (its bits): a `with_bounds` that keeps q_ref (new
        goals for a given start) copies them and writes the data. q_ref and p themselves are
        kept while the problem's data they are formed of are the same objects (read-only
        arrays, the final time, the parameters): a re-solve for a new goal from a given start
        forms neither again (NumPy's calls on them are a measurable part of the loop,
        benchmarks/peers.py resolve)."""
        start, goal = problem.q_start, problem.q_goal
        formed = vars(self).get("_q_ref_of")        # (q_start, q_goal, whether q_ref reads q_goal)
        if formed is None or start is not formed[0] or (formed[2] and goal is not formed[1]):
            q_ref = frozen(reference(start, goal))
            if "_q_ref" not in vars(self) or q_ref.tobytes() != self._q_ref.tobytes():
                q = self._x_layout.slice("q")
                self._open_bounds = tuple(frozen(np.concatenate([
                    bound[:q.start], np.tile(problem.state_bounds[side] - q_ref, problem.steps + 1),
                    bound[q.stop:]])) for side, bound in enumerate(self._open_bounds))
            self._q_ref, self._q_ref_of = q_ref, (start, goal, not np.isfinite(start).all())
        q_ref = self._q_ref
        sources = (problem.final_time, q_ref, problem.parameters, problem.p_start)
        if any(a is not b for a, b in zip(sources, vars(self).get("_p_of", (None,) * 4))):
            p_start = np.zeros(0) if problem.p_start is None else problem.p_start
            self._p = frozen(np.concatenate([problem.final_time.p_values, q_ref, problem.parameters.vector(),
                                             p_start]))
            self._p_of = sources
        lbx, ubx = (bound.copy() for bound in self._open_bounds)
        # the given data, fixed at `_data_entries`
        data = np.concatenate([problem.q_start - q_ref, problem.q_goal - q_ref, _start_velocity(problem),
                               problem.v_goal])
        fixed = np.isfinite(data)
        entries, values = self._data_entries[fixed], data[fixed]
        lbx[entries] = ubx[entries] = values
        if problem.path_constraints is not None:
            refuse_violated_ends(problem.path_constraints, problem, self._end_checks)
        self._lbx, self._ubx = frozen(lbx), frozen(ubx)

    nlp = property(lambda self: self._nlp, doc="The NLP's CasADi expressions (see the class).")
    separable = property(lambda self: self._separable, doc="The NLP as terms (`SeparableNLP`).")
    x_layout = property(lambda self: self._x_layout, doc="Named blocks of x.")
    p_layout = property(lambda self: self._p_layout, doc="Named blocks of p.")
    g_layout = property(lambda self: self._g_layout, doc="Named blocks of g.")
    dynamics_rows = property(lambda self: self._dynamics_rows, doc="Residual rows imposed per step.")
    x_scale = property(lambda self: self._x_scale, doc="IPOPT iterates on x / x_scale.")
    g_scale = property(lambda self: self._g_scale, doc="IPOPT imposes g_scale * g.")
    lbx = property(lambda self: self._lbx, doc="Lower bounds of x.")
    ubx = property(lambda self: self._ubx, doc="Upper bounds of x.")
    lbg = property(lambda self: self._lbg, doc="Lower bounds of g.")
    ubg = property(lambda self: self._ubg, doc="Upper bounds of g.")
    scaled_g_bounds = property(lambda self: self._scaled_g_bounds,
                               doc="(lbg * g_scale, ubg * g_scale), the bounds IPOPT imposes.")
    p = property(lambda self: self._p, doc="Values of the parameter vector p.")
    q_ref = property(lambda self: self._q_ref, doc="The configuration x is centered on.")
    velocity_bounded = property(lambda self: self._velocity_bounded,
                                doc="The entries of v with a finite velocity bound.")
    hulled_controls = property(lambda self: self._hulled,
                               doc="The controls bounded between their nodes (`control_hull`).")

    @property
    def structure(self):
        """A key of the NLP by value (`SeparableNLP.key`: its terms' Functions and index
        arrays): transcriptions with equal keys differ at most in the bounds and p."""
        return self._separable.key

    def momenta(self, x):
        """The momenta p_0 ... p_N, shape (N+1, n), of an NLP vector x (its block "p" when
        the momenta are variables, computed from x when substituted)."""
        return self._momenta(np.asarray(x, dtype=float), self._p).T

    def configurations(self, x):
        """The configurations q_0 ... q_N, shape (N+1, n), of an NLP vector x (whose block
        "q" holds q - q_ref)."""
        return self._x_layout.unpack(np.asarray(x, dtype=float), "q").T + self._q_ref

    def __repr__(self):
        return f"Transcription(x: {self._x_layout.size}, p: {self._p_layout.size}, g: {self._g_layout.size})"


def reference(q_start, q_goal):
    """q_ref, shape (n,): the given entries of q_start, else of q_goal, else 0. The NLP's
    configuration variables are q - q_ref, of the size of the motion rather than of the
    coordinates, so that IPOPT's steps and tolerances do not depend on where the motion
    takes place (e.g. map coordinates of 1e6 m)."""
    return np.where(np.isfinite(q_start), q_start, np.where(np.isfinite(q_goal), q_goal, 0.0))


def _start_velocity(problem):
    """The values of x's block "v_start": the problem's, or zeros (fixed, read by no row)
    when the start is given by its momentum."""
    return problem.v_start if problem.p_start is None else np.zeros_like(problem.v_start)
