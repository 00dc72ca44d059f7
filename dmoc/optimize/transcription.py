"""The DMOC transcription (consumer 2 of the step residual, its problem half): which rows
and costs of an OptimalControlProblem are evaluated at which steps, on which entries of
x and p, as the terms of a partially separable NLP (`dmoc.separable`). The step residual
of (37)/(41) (or (39)/(43)) is one term mapped over the steps; with the momenta
substituted, step k reads the window of steps k-1 and k, p_k = D2 L_d + f_d^+ of step k-1
(`dmoc._momentum`) entering its rows.
"""

import hashlib

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from ..principle.explicit import single_output
from .separable import SeparableNLP, Term, function_key

_FUNCTIONS = BoundedCache(128, "term_functions")   # term Functions by (`_functions_key`, term name): not per N


def transcribe(problem):
    """The NLP of `problem` and its momenta.

    Parameters
    ----------
    problem : OptimalControlProblem
        With `x_layout`, `p_layout`, `g_layout` and `dynamics_rows` set.

    Returns
    -------
    nlp : SeparableNLP
    momenta : callable
        ``momenta(x, p) -> P``, x and p numpy vectors, P of shape (n, N+1): p_0 ... p_N
        (the block "p" when the momenta are variables, else p_0 and the explicit p_{k+1}
        of every step).
    """
    X, P, G = (_indices(lay) for lay in (problem.x_layout, problem.p_layout, problem.g_layout))
    h = ("x", X["h"]) if problem.free_time else ("p", P["h"])
    step = _StepSlots(problem, X, h, P)
    terms = step.dynamics(G["dynamics"]) + [step.start(G), step.goal(G)]
    if problem.g_layout.numel("path"):
        terms.append(step.term("path", step.at(0, problem.steps),
                               lambda s: (0, problem._path(**_args(problem._path, s))["g"]), G["path"]))
    nlp = SeparableNLP(problem.x_layout.size, problem.p_layout.size, problem.g_layout.size, terms)
    return nlp, step.momenta()


class _StepSlots:
    """The windows of x and p that the step terms read, by slot name. A slot of source
    "q" holds configurations q - q_ref (x is centered on the boundary data, see
    `OptimalControlProblem.q_ref`); the term adds q_ref back."""

    def __init__(self, problem, X, h, P):
        self.problem, self.X, self.h, self.N = problem, X, h, problem.steps
        self.q_ref, self.w = P["q_ref"], ("p", P["w"])
        self.residual, self.key = problem.residual, _functions_key(problem)
        if problem.momenta_substituted:
            self.p1 = single_output(self.residual, "p1")
            self.rows = single_output(self.residual, "rows")

    @property
    def cost(self):
        """C_d(q0, q1, s, u, h, w) of the running cost (built only when a term is)."""
        return self.problem.disc.discrete_cost(self.problem._running)

    def at(self, first, stop, suffix=""):
        """Slots q0, q1, lam, s, u (steps first ... stop - 1), names + suffix, and h, w."""
        X = self.X
        slots = {"q0": ("q", X["q"][:, first:stop]), "q1": ("q", X["q"][:, first + 1:stop + 1]),
                 "lam": ("x", X["lam"][:, first:stop]), "s": ("x", X["s"][:, first:stop]),
                 "u": ("x", X["u"][:, first:stop])}
        return {**{k + suffix: v for k, v in slots.items()}, "h": self.h, "w": self.w}

    def term(self, name, slots, body, g_index):
        """`_term` with q_ref added to the slots of source "q" and the problem's scales, its
        Function built once per `_functions_key` and scales (the index arrays are this
        problem's)."""
        return _term(name, {**slots, "q_ref": ("p", self.q_ref)}, body, g_index, (self.key, name),
                     (self.problem.x_scale, self.problem.g_scale))

    def _previous_momentum(self, s):
        """p_k of the window's previous step (slots with suffix "_prev")."""
        names = self.p1.name_in()
        return self.p1(**{k: s[k if k == "h" else k + "_prev"] for k in names})["p1"]

    def dynamics(self, rows):
        """The residual at every step: its rows and the step cost C_d."""
        N, R = self.N, self.residual
        if not self.problem.momenta_substituted:
            slots = {**self.at(0, N), "p0": ("x", self.X["p"][:, :N]), "p1": ("x", self.X["p"][:, 1:])}
            return [self.term("dynamics", slots, lambda s: (self._cost(s), R.function(**_args(R.function, s))["r"]),
                          rows)]
        first = {**self.at(0, 1), "p0": ("x", self.X["p"][:, :1])}
        later = {**self.at(1, N), **self.at(0, N - 1, "_prev")}
        return [self.term("dynamics_0", first, lambda s: (self._cost(s), self._rows(s)), rows[:, :1]),
                self.term("dynamics", later, lambda s: (self._cost(s), self._rows(
                    {**s, "p0": self._previous_momentum(s)})), rows[:, 1:])]

    def _cost(self, s):
        return self.cost(**_args(self.cost, s))["C_d"]

    def _rows(self, s):
        return self.rows(**_args(self.rows, s))["rows"]

    def start(self, G):
        """Start momentum rows (and A(q_0) v_start = 0 where that end is partly free)."""
        problem, X = self.problem, self.X
        condition = problem.formulation.momentum_conditions(problem.disc.system)[0]
        slots = {"q": ("q", X["q"][:, :1]), "p": ("x", X["p"][:, :1]),
                 "v": ("x", X["v_start"]), "mu": ("x", X["mu"])}
        return self.term("start", slots, lambda s: (0, self._boundary_rows(condition, s, "start", "mu")),
                     np.vstack([G["start"], G["start_velocity"]]))

    def goal(self, G):
        """Goal momentum rows at p_N, the velocity rows and the terminal cost."""
        problem, X, N = self.problem, self.X, self.N
        condition = problem.formulation.momentum_conditions(problem.disc.system)[1]
        slots = {"q": ("q", X["q"][:, N:]), "v": ("x", X["v_goal"]), "nu": ("x", X["nu"]), "w": self.w}
        if problem.momenta_substituted:
            slots.update(self.at(N - 1, N, "_prev"))
        else:
            slots["p"] = ("x", X["p"][:, N:])

        def body(s):
            if problem.momenta_substituted:
                s = {**s, "p": self._previous_momentum(s)}
            terminal = 0 if problem._terminal is None else problem._terminal(s["q"], s["v"], s["w"])
            return terminal, self._boundary_rows(condition, s, "goal", "nu")
        return self.term("goal", slots, body, np.vstack([G["goal"], G["goal_velocity"]]))

    def _boundary_rows(self, condition, s, end, impulse):
        rows = [condition(s["q"], s["p"], s["v"], s[impulse])]
        if self.problem.g_layout.numel(end + "_velocity"):
            rows.append(ca.mtimes(self.problem.disc.system.constraint_matrix(s["q"]), s["v"]))
        return ca.vertcat(*rows)

    def momenta(self):
        """``momenta(x, p) -> P`` (n, N+1), the momenta at NLP values x and p (numbers): the
        block "p", or p_0 and the explicit p_{k+1} of every step. It holds the index
        arrays and p1 only, not the problem (copies from `with_boundary` share it)."""
        X, N, q_ref = self.X, self.N, self.q_ref
        if not self.problem.momenta_substituted:
            return lambda x, p: x[X["p"]]
        p1, slots = self.p1, self.at(0, N, "_prev")
        windows = {k: slots[k if k == "h" else k + "_prev"] for k in p1.name_in()}

        def momenta(x, p):
            source = {"x": x, "q": x, "p": p}
            args = {k: source[src][_broadcast(index, N)] + (p[q_ref] if src == "q" else 0)
                    for k, (src, index) in windows.items()}
            return np.hstack([x[X["p"][:, :1]], np.array(p1.map(N)(**args)["p1"])])
        return momenta


def _term(name, slots, body, g_index, key, scales):
    """A Term from named slots {name: (source, index array (size, M), or (size, 1) shared
    by every instance)} and ``body(symbols) -> (f, g)``, its Function cached under `key`,
    the slots' aliasing and their scales. Source "x" or "p": entries of x or p; "q":
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
    wide = {k: (src, _broadcast(index, M)) for k, (src, index) in slots.items()}
    owner = {}                          # slot -> the first slot reading the same entries
    for k, (src, index) in wide.items():
        same = [o for o in owner if owner[o] == o and wide[o][0] == src
                and np.array_equal(wide[o][1], index)] if M else []
        owner[k] = same[0] if same else k
    parts = {"x": [k for k, (s, _) in slots.items() if s in ("x", "q") and owner[k] == k],
             "p": [k for k, (s, _) in slots.items() if s == "p" and owner[k] == k]}

    def build():
        symbols = {k: ca.SX.sym(k, index.shape[0]) for k, (_, index) in slots.items() if owner[k] == k}
        values = {k: _scaled(symbols[owner[k]], scale[k]) for k in slots}
        f, g = body({k: values[k] + values["q_ref"] if src == "q" else values[k]
                     for k, (src, _) in slots.items()})
        g = _scaled(ca.SX(g), row_scale)
        z, w = (_stack([symbols[k] for k in parts[src]]) for src in ("x", "p"))
        function = ca.Function(name, [z, w], [ca.SX(f), ca.SX(g)], ["z", "w"], ["f", "g"])
        return function, function_key(function)
    index = {src: np.vstack([wide[k][1] for k in parts[src]] or [np.zeros((0, M), int)])
             for src in ("x", "p")}
    aliases = tuple(sorted((k, o) for k, o in owner.items() if k != o))
    scaling = repr((row_scale.tolist(), sorted((k, v.tolist()) for k, v in scale.items())))
    function, key_of_function = _FUNCTIONS.get((key, aliases, scaling), build)
    return Term(function, index["x"], index["p"], g_index, key_of_function)


def _functions_key(problem):
    """What the term Functions of `problem` depend on: the residual (system, rule,
    formulation), how the momenta enter, the free time, the velocity rows and the user's
    cost and path Functions (by value)."""
    user = (problem._running, problem._terminal, problem._path)
    digest = hashlib.sha256("\0".join("" if f is None else f.serialize() for f in user).encode())
    return (problem.residual.key, problem.momenta_substituted, problem.free_time,
            problem.g_layout.numel("start_velocity"), problem.g_layout.numel("goal_velocity"),
            digest.hexdigest())


def _indices(layout):
    """{block: its flat indices as a (rows, cols) int array}."""
    every = np.arange(layout.size)
    return {name: layout.unpack(every, name) for name in layout.blocks}


def _broadcast(index, M):
    return np.broadcast_to(index, (index.shape[0], M)) if index.shape[1] == 1 else index


def _scaled(symbol, scale):
    """symbol * scale (entrywise), symbol itself where every factor is 1."""
    return symbol if (scale == 1).all() else symbol * ca.DM(scale)


def _stack(symbols):
    return ca.vertcat(*symbols) if symbols else ca.SX(0, 1)


def _args(function, symbols):
    """The entries of `symbols` that `function` takes, by its input names."""
    return {k: symbols[k] for k in function.name_in()}
