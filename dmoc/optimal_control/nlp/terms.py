"""The terms of the DMOC NLP (consumer 2 of the step residual): which rows and costs of an
OptimalControlProblem are evaluated at which steps, on which entries of x and p, as the
terms of a partially separable NLP (`dmoc.optimal_control.nlp.separable`). The step residual of
(37)/(41) (or (39)/(43)) is mapped over the steps as the problem's momentum treatment says
(`dmoc.optimal_control.nlp.momenta`); the boundary rows and the terminal cost are terms of
their own, and so are the path constraints and velocity bounds (`path_terms`: inside the
steps and at every knot).
"""

import functools
import hashlib

import casadi as ca
import numpy as np

from ..._util import typed_ops
from ..._util.cache import BoundedCache
from .control_hull import hull_terms
from .path_terms import path_terms
from .separable import SeparableNLP, Term, function_key

_SCALES = BoundedCache(64, "scale_vectors")       # the SX of a scale vector (n,), by its dtype and bytes
_FUNCTIONS = BoundedCache(128, "term_functions")   # term Functions by (`_functions_key`, term name): not per N


def transcribe(problem, layouts, scales):
    """The NLP of `problem` and its momenta.

    Parameters
    ----------
    problem : OptimalControlProblem
        The statement: its residual, costs, path constraints, final time and momenta.
    layouts : tuple of Layout
        (x_layout, p_layout, g_layout) of `Transcription`.
    scales : tuple of ndarray
        (x_scale, g_scale) of `dmoc.optimal_control.nlp.scaling.nlp_scales`.

    Returns
    -------
    nlp : SeparableNLP
    momenta : callable
        ``momenta(x, p) -> P``, x and p numpy vectors, P of shape (n, N+1): p_0 ... p_N
        (`momenta_function` of the problem's momentum treatment).
    """
    X, P, G = (block_indices(lay) for lay in layouts)
    step = _StepSlots(problem, X, P, G, scales, (layouts[0].size, layouts[1].size))
    terms = problem.momentum_treatment.dynamics_terms(step, G["dynamics"]) + [step.start(), step.goal()]
    terms += path_terms(step, G) + hull_terms(step, G)
    nlp = SeparableNLP(*(lay.size for lay in layouts), terms)
    return nlp, problem.momentum_treatment.momenta_function(step)


class _StepSlots:
    """The windows of x and p that the step terms read, by slot name. A slot of source
    "q" holds configurations q - q_ref (x is centered on the boundary data, see
    `Transcription.q_ref`); the term adds q_ref back. `sizes` are those of x and p."""

    def __init__(self, problem, X, P, G, scales, sizes):
        self.problem, self.X, self.P, self.G, self.N = problem, X, P, G, problem.steps
        self.n_x, self.n_p = sizes
        self.scales = scales
        self.h = problem.final_time.slot(X, P)
        self.q_ref = P["q_ref"]
        self.w_steps = P["w"][:, 0][problem.parameters.schedule.step_indices()]
        self.key = _functions_key(problem, G)

    @functools.cached_property
    def cost(self):
        """C_d(q0, q1, s, u, h, w) of the running cost, w the step's vector of parameters
        (built when a term first reads it, once)."""
        return self.problem.disc.discrete_cost(self.problem.running_cost,
                                               self.problem.parameters.schedule.point_function())

    def at(self, first, stop, suffix=""):
        """Slots q0, q1, lam, s, u and w (the steps' vectors of parameters,
        `ParameterSchedule.step_indices`) of steps first ... stop - 1, names + suffix, and
        h."""
        X, w = self.X, self.w_steps
        slots = {"q0": ("q", X["q"][:, first:stop]), "q1": ("q", X["q"][:, first + 1:stop + 1]),
                 "lam": ("x", X["lam"][:, first:stop]), "s": ("x", X["s"][:, first:stop]),
                 "u": ("x", X["u"][:, first:stop]),
                 "w": ("p", w if w.shape[1] == 1 else w[:, first:stop])}
        return {**{k + suffix: v for k, v in slots.items()}, "h": self.h}

    def term(self, name, slots, body, g_index):
        """`slot_term` with q_ref added to the slots of source "q" and the problem's scales, its
        Function built once per `_functions_key` and scales (the index arrays are this
        problem's)."""
        return slot_term(name, {**slots, "q_ref": ("p", self.q_ref)}, body, g_index, (self.key, name),
                     self.scales)

    def step_cost(self, s):
        """C_d of the step in the symbols `s`."""
        return self.cost(**inputs_of(self.cost, s))["C_d"]

    def start(self):
        """Start momentum rows (and A(q_0) v_start = 0 where that end is partly free); with
        a given start momentum (block "p_start" of p) the formulation's row with p_start in
        place of dL/dv(q_0, v_start): p_0 - p_start (+ A(q_0)^T mu for the (-) form)."""
        problem, X, G = self.problem, self.X, self.G
        condition = problem.formulation.momentum_conditions(problem.disc.system)[0]
        slots = {"q": ("q", X["q"][:, :1]), "p": ("x", X["p"][:, :1]),
                 "v": ("x", X["v_start"]), "mu": ("x", X["mu"])}
        if problem.p_start is not None:
            slots["p_start"] = ("p", self.P["p_start"])

            def body(s):        # (p_0 - dL/dv + impulse) - (p_start - dL/dv)
                return 0, (condition(s["q"], s["p"], s["v"], s["mu"])
                           - condition(s["q"], s["p_start"], s["v"], ca.DM.zeros(s["mu"].shape)))
        else:
            def body(s):
                return 0, self._boundary_rows(condition, s, "start", "mu")
        return self.term("start", slots, body, np.vstack([G["start"], G["start_velocity"]]))

    def goal(self):
        """Goal momentum rows at p_N, the velocity rows and the terminal cost."""
        problem, X, G, N = self.problem, self.X, self.G, self.N
        condition = problem.formulation.momentum_conditions(problem.disc.system)[1]
        momenta, terminal = problem.momentum_treatment, problem.terminal_cost
        last = self.at(N - 1, N)
        slots = {"q": ("q", X["q"][:, N:]), "v": ("x", X["v_goal"]), "nu": ("x", X["nu"]),
                 "w": last["w"], "h": last["h"], **momenta.goal_slots(self)}

        def body(s):        # the terminal cost reads the parameters at q_N: the end of step N-1
            s = {**s, "p": momenta.goal_momentum(s)}
            w = problem.parameters.schedule.at(s["w"], 1, s["h"])
            cost = 0 if terminal is None else terminal(s["q"], s["v"], w)
            return cost, self._boundary_rows(condition, s, "goal", "nu")
        return self.term("goal", slots, body, np.vstack([G["goal"], G["goal_velocity"]]))

    def _boundary_rows(self, condition, s, end, impulse):
        rows = [condition(s["q"], s["p"], s["v"], s[impulse])]
        if self.G[end + "_velocity"].size:
            rows.append(ca.mtimes(self.problem.disc.system.constraint_matrix(s["q"]), s["v"]))
        return ca.vertcat(*rows)


def slot_term(name, slots, body, g_index, key, scales, *, plain=False):
    """A Term from named slots {name: (source, index array (size, M), or (size, 1) shared
    by every instance)} and ``body(symbols) -> (f, g)``, its Function cached under `key`,
    the slots' aliasing and their scales. With `plain` (`key` made of strings, numbers and
    tuples only, whose repr is its value) the Term's `function_key` is the SHA-256 of that
    cache key's repr, not of the Function's serialization (0.2 ms for a group step). Source "x" or "p": entries of x or p; "q":
    entries of x holding q - q_ref, the body given q (slot "q_ref" from p). Slots that
    read the same entries (q1 of the previous step and q0 of this one) are one input of
    the Term, so that each instance reads an entry of x once (`dmoc.separable.Term`).
    `scales` = (x_scale, g_scale) of `dmoc.scaling`: the Term reads x / x_scale and fills
    g_scale * g (each constant over the instances)."""
    M = g_index.shape[1]
    x_scale, g_scale = scales
    scale = {k: x_scale[index[:, 0]] if src != "p" and index.shape[1] else np.ones(index.shape[0])
             for k, (src, index) in slots.items()}
    row_scale = g_scale[g_index[:, 0]] if M else np.ones(g_index.shape[0])
    wide = {k: (src, broadcast(index, M)) for k, (src, index) in slots.items()}
    owner = {}                          # slot -> the first slot reading the same entries
    for k, (src, index) in wide.items():
        same = [o for o in owner if owner[o] == o and wide[o][0] == src
                and np.array_equal(wide[o][1], index)] if M else []
        owner[k] = same[0] if same else k
    parts = {"x": [k for k, (s, _) in slots.items() if s in ("x", "q") and owner[k] == k],
             "p": [k for k, (s, _) in slots.items() if s == "p" and owner[k] == k]}

    def build():
        # one symbol for z and one for w, split into the slots (two calls, not one a slot)
        z, w = (ca.SX.sym(label, sum(slots[k][1].shape[0] for k in parts[src]))
                for label, src in (("z", "x"), ("w", "p")))
        symbols = {}
        for src, whole in (("x", z), ("p", w)):
            sizes = np.cumsum([0] + [slots[k][1].shape[0] for k in parts[src]]).tolist()
            symbols.update(zip(parts[src], ca.vertsplit(whole, sizes) if parts[src] else []))
        values = {k: _scaled(symbols[owner[k]], scale[k]) for k in slots}
        f, g = body({k: typed_ops.plus(values[k], values["q_ref"]) if src == "q" else values[k]
                     for k, (src, _) in slots.items()})
        f, g = typed_ops.sx(f), _scaled(typed_ops.sx(g), row_scale)
        function = ca.Function(name, [z, w], [f, g], ["z", "w"], ["f", "g"])
        by_value = (hashlib.sha256(repr((name, key, aliases, scaling)).encode()).hexdigest() if plain
                    else function_key(function))
        return function, by_value
    index = {src: np.vstack([wide[k][1] for k in parts[src]] or [np.zeros((0, M), int)])
             for src in ("x", "p")}
    aliases = tuple(sorted((k, o) for k, o in owner.items() if k != o))
    scaling = repr((row_scale.tolist(), sorted((k, v.tolist()) for k, v in scale.items())))
    function, key_of_function = _FUNCTIONS.get((key, aliases, scaling), build)
    return Term(function, index["x"], index["p"], g_index, key_of_function)


def _functions_key(problem, G):
    """What the term Functions of `problem` depend on: the residual (system, rule,
    formulation), how the momenta enter, where h lives, the velocity rows (G: the row
    indices by block), the kinds of the parameters (fixed, per step, per knot, the clock),
    the velocity-bounded entries and the user's cost and path Functions (by value)."""
    user = (problem.running_cost, problem.terminal_cost, problem.path_constraints)
    digest = hashlib.sha256("\0".join("" if f is None else f.serialize() for f in user).encode())
    return (problem.residual.key, problem.momentum_treatment.name, problem.final_time.free,
            G["start_velocity"].size, G["goal_velocity"].size, problem.p_start is not None,
            problem.parameters.schedule.key, tuple(problem.velocity_bounded), digest.hexdigest())


def block_indices(layout):
    """{block: its flat indices as a (rows, cols) int array}."""
    every = np.arange(layout.size)
    return {name: layout.unpack(every, name) for name in layout.blocks}


def broadcast(index, M):
    """An index array (rows, 1) shared by M instances as (rows, M); others as they are."""
    return np.broadcast_to(index, (index.shape[0], M)) if index.shape[1] == 1 else index


def _scaled(symbol, scale):
    """symbol * scale (entrywise), symbol itself where every factor is 1; the SX constant of
    `scale` made once per value (`_SCALES`: a problem's terms share a few scale vectors)
    and multiplied in through `typed_ops` (the product's nodes are the same; CasADi's
    generic product converts a DM anew at every call, 30 us of the 40)."""
    if (scale == 1).all():
        return symbol
    constant = _SCALES.get((scale.dtype.str, scale.tobytes()), lambda: ca.SX(ca.DM(scale)))
    return typed_ops.times(symbol, constant)


def inputs_of(function, symbols):
    """The entries of `symbols` that `function` takes, by its input names."""
    return {k: symbols[k] for k in function.name_in()}
