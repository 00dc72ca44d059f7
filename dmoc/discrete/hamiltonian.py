"""Discretization of a Hamiltonian system: right and left discrete Hamiltonians
H_d+(q_k, p_{k+1}) and H_d-(p_k, q_{k+1}) (type-2 and type-3 generating functions, Lall &
West), by named rules or supplied by the user, and the discrete Legendre transform of a
Lagrangian discretization. The discrete constraints are those of (28) with the midpoint
retraction (and g(q_{k+1}) = 0 for holonomic constraints), the discrete forces the virtual
work of f(q, p, u) at the rule's samples. The residual rows come from the sums (48)/(49)
(`dmoc.formulations.hamiltonian`).
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from ..mechanics.system import HamiltonianSystem
from .discretization import Discretization, running_integrand
from .._util.layout import step_symbols
from .rules import Midpoint
from ..errors import InputError, InputTypeError


@dataclass(frozen=True)
class HamiltonianRule:
    """A pair of discrete Hamiltonians with their stage unknowns.

    Subclasses (or instances with other data) define `right` and `left`:
    ``right(H, q0, p1, s, h) -> (H_d+, samples)`` and ``left(H, p0, q1, s, h) -> (H_d-,
    samples)``, H the Function H(q, p), s the stage unknowns (``n_stage_blocks * n`` rows;
    H_d is extremal in them), samples a list of (weight, q, p) at which the force
    f(q, p, u) does virtual work weight f . delta q.

    Attributes
    ----------
    name : str
    order : int
    n_stage_blocks : int
        Stage unknowns per step, in units of n.
    control_nodes : tuple of float
        ``(0.5,)``: one control held over each step.
    """

    name: str
    order: int
    n_stage_blocks: int = 0
    control_nodes: tuple = (0.5,)

    def right(self, H, q0, p1, s, h):
        raise NotImplementedError

    def left(self, H, p0, q1, s, h):
        raise NotImplementedError

    def control_at(self, u, c):
        """The control at step time c: the one held over the step."""
        return u

    def stage_guess(self, q, p):
        """Stage values for an initial guess from knot values q, p (N+1, n): (N, n_stages).
        Rules with stages override it."""
        return np.zeros((q.shape[0] - 1, 0))


class SymplecticEuler(HamiltonianRule):
    """H_d+ = p1 . q0 + h H(q0, p1), H_d- = -p0 . q1 + h H(q1, p0): the two symplectic
    Euler methods (order 1), no stages; the force acts at the same sample.

    >>> SymplecticEuler().order
    1
    """

    def __init__(self):
        super().__init__("symplectic-euler", 1)

    def right(self, H, q0, p1, s, h):
        return ca.dot(p1, q0) + h * H(q0, p1), [(h, q0, p1)]

    def left(self, H, p0, q1, s, h):
        return -ca.dot(p0, q1) + h * H(q1, p0), [(h, q1, p0)]

    def __repr__(self):
        return "SymplecticEuler()"


class HamiltonianMidpoint(HamiltonianRule):
    """The Galerkin discrete Hamiltonians on a linear q and a constant P with the midpoint
    quadrature (after Leok & Zhang), order 2; stages s = (Q, P):

    H_d+(q0, p1) = ext_{Q, P} p1 . Q - P . (Q - q0) + h H((q0 + Q)/2, P)  (Q = q_{k+1}),
    H_d-(p0, q1) = ext_{Q, P} -p0 . Q - P . (q1 - Q) + h H((Q + q1)/2, P)  (Q = q_k).

    Both give the implicit midpoint rule; the force acts at the midpoint.

    >>> HamiltonianMidpoint().n_stage_blocks
    2
    """

    def __init__(self):
        super().__init__("midpoint", 2, 2)

    def stage_guess(self, q, p):
        """Q = q_{k+1} (+; q_k for -, both near), P = (p_k + p_{k+1})/2."""
        return np.hstack([q[1:], (p[:-1] + p[1:]) / 2])

    def right(self, H, q0, p1, s, h):
        n = q0.numel()
        Q, P = s[:n], s[n:]
        mid = (q0 + Q) / 2
        return ca.dot(p1, Q) - ca.dot(P, Q - q0) + h * H(mid, P), [(h, mid, P)]

    def left(self, H, p0, q1, s, h):
        n = q1.numel()
        Q, P = s[:n], s[n:]
        mid = (Q + q1) / 2
        return -ca.dot(p0, Q) - ca.dot(P, q1 - Q) + h * H(mid, P), [(h, mid, P)]

    def __repr__(self):
        return "HamiltonianMidpoint()"


HAMILTONIAN_RULES = {rule().name: rule for rule in (SymplecticEuler, HamiltonianMidpoint)}


class HamiltonianDiscretization(Discretization):
    """Discrete data of a HamiltonianSystem (or of a Lagrangian discretization's Legendre
    transform) on a grid of step `h`; build it with `dmoc.discretize` or
    `dmoc.discrete_legendre`.

    Attributes
    ----------
    system, h, rule, key, n_stages, n_multipliers, n_controls
        As for `Discretization`; `rule` is a HamiltonianRule.
    right_hamiltonian, left_hamiltonian : casadi.Function
        ``H_d+(q0, p1, s, h)`` and ``H_d-(p0, q1, s, h)``, scalars, stage-extended.
    right_force, left_force : casadi.Function
        ``(q0, p1, s, u, h) -> (f_q0, f_stage)`` and ``(p0, q1, s, u, h) -> (f_q1,
        f_stage)``: the discrete virtual work of f on delta q_k (resp. delta q_{k+1}) and on
        the stages, for the (+) and (-) forms.
    discrete_constraint, midpoint_state, step_energy
        As for `Discretization`; the energy of a step is (H(q0, p0) + H(q1, p1))/2.
    """

    family = "hamiltonian"

    def __init__(self, system, h, rule="midpoint"):
        checks.instance("system", system, HamiltonianSystem, "a HamiltonianSystem")
        rule = as_hamiltonian_rule(rule)
        self._setup(system, h, rule, _HAMILTONIAN_DATA.get((system.key, rule), lambda: _data(system, rule)))

    def _setup(self, system, h, rule, data):
        self.system, self.rule = system, rule
        self.h = checks.positive_float("h", h)
        self.key = (system.key, rule)
        self.n_stages = rule.n_stage_blocks * system.n
        self.n_multipliers = system.m
        self.n_controls = len(rule.control_nodes) * system.n_u
        (self.right_hamiltonian, self.left_hamiltonian, self.right_force, self.left_force,
         self.discrete_constraint, self.midpoint_state, self.step_energy) = data

    def discrete_cost(self, running_cost):
        """C_d(q0, q1, s, u, h, w) = h running_cost((q0 + q1)/2, (q1 - q0)/h, u, w): the
        step integral by the midpoint rule on the chord (the stages are momenta here)."""
        running_cost = running_integrand(self.system, running_cost)
        x = _cost_symbols(self, running_cost)
        q0, q1, h = x["q0"], x["q1"], x["h"]
        return _cost_function(x, h * running_cost((q0 + q1) / 2, (q1 - q0) / h, x["u"], x["w"]))

    def __repr__(self):
        return f"HamiltonianDiscretization({self.system!r}, h={self.h!r}, rule={self.rule!r})"


_HAMILTONIAN_DATA = BoundedCache(32, "hamiltonian_data")


def as_hamiltonian_rule(rule):
    """A HamiltonianRule from an instance or one of the names in HAMILTONIAN_RULES."""
    if isinstance(rule, HamiltonianRule):
        return rule
    return HAMILTONIAN_RULES[checks.choice("rule", rule, tuple(HAMILTONIAN_RULES))]()


def _cost_symbols(disc, running_cost):
    """The step symbols of `disc` and w, the parameters `running_cost` takes last."""
    return {**step_symbols(disc.system.n, disc.n_stages, disc.n_controls),
            "w": ca.SX.sym("w", running_cost.size1_in(3))}


def _cost_function(x, C_d):
    """The Function C_d(q0, q1, s, u, h, w) of the step symbols `x`."""
    names = ["q0", "q1", "s", "u", "h", "w"]
    return ca.Function("C_d", [x[k] for k in names], [C_d], names, ["C_d"])


def _virtual_work(force, samples, ends, s, u):
    """Coefficients of delta(end) and delta(s) in sum_i w_i f(q_i, p_i, u) . delta q_i,
    the force frozen."""
    frozen = [(w * force(q, p, u), q) for w, q, p in samples]
    return tuple(sum(ca.mtimes(ca.jacobian(q, x).T, fw) for fw, q in frozen) if x.numel()
                 else ca.SX(0, 1) for x in (ends, s))


def _data(system, rule):
    """The Functions of a HamiltonianDiscretization, h an input (cached by system and rule)."""
    n = system.n
    x = step_symbols(n, rule.n_stage_blocks * n, len(rule.control_nodes) * system.n_u)
    H = system.hamiltonian
    Hp, right_samples = rule.right(H, x["q0"], x["p1"], x["s"], x["h"])
    Hm, left_samples = rule.left(H, x["p0"], x["q1"], x["s"], x["h"])
    u = x["u"][:system.n_u]          # one control held over the step
    fp = _virtual_work(system.force, right_samples, x["q0"], x["s"], u)
    fm = _virtual_work(system.force, left_samples, x["q1"], x["s"], u)
    return (*_end_functions(x, Hp, Hm, fp, fm), *_chord_functions(system, x))


def _end_functions(x, Hp, Hm, fp, fm):
    """H_d+, H_d-, and their discrete forces as named Functions of the step symbols `x`."""
    args = {k: [x[a] for a in k.split(",")] for k in ("q0,p1,s,h", "p0,q1,s,h", "q0,p1,s,u,h", "p0,q1,s,u,h")}
    names = {k: k.split(",") for k in args}
    return (ca.Function("H_d_plus", args["q0,p1,s,h"], [Hp], names["q0,p1,s,h"], ["H_d"]),
            ca.Function("H_d_minus", args["p0,q1,s,h"], [Hm], names["p0,q1,s,h"], ["H_d"]),
            ca.Function("f_d_plus", args["q0,p1,s,u,h"], list(fp), names["q0,p1,s,u,h"], ["f_q0", "f_stage"]),
            ca.Function("f_d_minus", args["p0,q1,s,u,h"], list(fm), names["p0,q1,s,u,h"], ["f_q1", "f_stage"]))


def _chord_functions(system, x):
    """omega_d (28) with the midpoint retraction and g(q1); the midpoint state on the chord;
    the step energy (H(q0, p0) + H(q1, p1))/2."""
    rule, none = Midpoint(), ca.SX(0, 1)
    q0, q1, s, h = x["q0"], x["q1"], x["s"], x["h"]
    omega_d = ca.vertcat(rule.discrete_constraint(system.nonholonomic_matrix, q0, q1, none, h),
                         rule.holonomic_constraint(system.holonomic, q0, q1, none))
    E = (system.hamiltonian(q0, x["p0"]) + system.hamiltonian(q1, x["p1"])) / 2
    return (ca.Function("omega_d", [q0, q1, s, h], [omega_d], ["q0", "q1", "s", "h"], ["omega_d"]),
            ca.Function("midpoint_state", [q0, q1, s, h], [(q0 + q1) / 2, (q1 - q0) / h],
                        ["q0", "q1", "s", "h"], ["q", "v"]),
            ca.Function("step_energy", [q0, x["p0"], q1, x["p1"], s, h], [E],
                        ["q0", "p0", "q1", "p1", "s", "h"], ["E"]))


class LegendreRule(HamiltonianRule):
    """The discrete Legendre transform of a Lagrangian rule (Lall & West):
    H_d+(q0, p1) = ext_Q p1 . Q - L_d(q0, Q, sigma) and
    H_d-(p0, q1) = ext_Q -p0 . Q - L_d(Q, q1, sigma), stages s = (Q, sigma), sigma the
    Lagrangian rule's own stages; the forces are the Lagrangian rule's f_d^-+ (`lagrangian`
    is the Lagrangian discretization's data, not part of the value)."""

    def __init__(self, lagrangian_rule):
        super().__init__(f"legendre-{lagrangian_rule.name}", lagrangian_rule.order,
                         1 + lagrangian_rule.n_stages, lagrangian_rule.control_nodes)
        object.__setattr__(self, "lagrangian_rule", lagrangian_rule)

    def stage_guess(self, q, p):
        """Q = q_{k+1}, the Lagrangian rule's stages on the chords."""
        return np.hstack([q[1:], self.lagrangian_rule.stage_guess(q, p)])


def discrete_legendre(disc):
    """The Hamiltonian discretization whose H_d+ (and H_d-) is the discrete Legendre
    transform of the Lagrangian discretization `disc` (Lall & West), implicit: the
    extremizing configuration is a stage unknown of the residual.

    Simulated from the same (q_0, p_0), it reproduces the Lagrangian trajectory (the step
    equations are (37)/(41) written as (39)/(43)).

    Parameters
    ----------
    disc : Discretization
        A Lagrangian discretization; with constraints, a stage-free rule (the multipliers
        of a Lagrangian stage rule sit at its interior nodes, which (38)/(42) do not have).

    Returns
    -------
    HamiltonianDiscretization
    """
    if not isinstance(disc, Discretization) or isinstance(disc, HamiltonianDiscretization):
        raise InputTypeError(f"`disc` must be a Lagrangian Discretization; got {type(disc).__name__}.")
    if disc.n_multipliers > disc.system.m:
        raise InputError(f"`disc` must have a stage-free rule when it has constraints: rule "
                         f"{disc.rule.name!r} puts multipliers at its interior nodes.")
    return LegendreDiscretization(disc)


class LegendreDiscretization(HamiltonianDiscretization):
    """The HamiltonianDiscretization of `discrete_legendre`: stages (Q, sigma), the running
    cost integrated by the Lagrangian rule on (q0, q1, sigma)."""

    def __init__(self, lagrangian):
        rule = LegendreRule(lagrangian.rule)
        self.lagrangian = lagrangian
        self._setup(lagrangian.system, lagrangian.h, rule, _HAMILTONIAN_DATA.get(
            (lagrangian.system.key, rule), lambda: _legendre_data(lagrangian)))

    def discrete_cost(self, running_cost):
        """C_d of the Lagrangian rule, the stage block Q (= the end configuration) left out."""
        running_cost = running_integrand(self.system, running_cost)
        C = self.lagrangian.discrete_cost(running_cost)
        x = _cost_symbols(self, running_cost)
        return _cost_function(x, C(x["q0"], x["q1"], x["s"][self.system.n:], x["u"], x["h"], x["w"]))


def _legendre_data(disc):
    n, ns = disc.system.n, disc.n_stages
    x = step_symbols(n, n + ns, disc.n_controls)
    Q, sigma = x["s"][:n], x["s"][n:]
    L_d = disc.discrete_lagrangian
    Hp = ca.dot(x["p1"], Q) - L_d(x["q0"], Q, sigma, x["h"])
    Hm = -ca.dot(x["p0"], Q) - L_d(Q, x["q1"], sigma, x["h"])
    f_minus, f_plus, f_sigma = disc.discrete_force(x["q0"], Q, sigma, x["u"], x["h"])
    g_minus, g_plus, g_sigma = disc.discrete_force(Q, x["q1"], sigma, x["u"], x["h"])
    fp = (f_minus, ca.vertcat(f_plus, f_sigma))
    fm = (g_plus, ca.vertcat(g_minus, g_sigma))
    E = disc.step_energy(x["q0"], x["p0"], x["q1"], x["p1"], sigma, x["h"])
    omega = disc.discrete_constraint(x["q0"], x["q1"], sigma, x["h"])
    q_mid, v_mid = disc.midpoint_state(x["q0"], x["q1"], sigma, x["h"])
    q0, q1, s, h = x["q0"], x["q1"], x["s"], x["h"]
    return (*_end_functions(x, Hp, Hm, fp, fm),
            ca.Function("omega_d", [q0, q1, s, h], [omega], ["q0", "q1", "s", "h"], ["omega_d"]),
            ca.Function("midpoint_state", [q0, q1, s, h], [q_mid, v_mid], ["q0", "q1", "s", "h"], ["q", "v"]),
            ca.Function("step_energy", [q0, x["p0"], q1, x["p1"], s, h], [E],
                        ["q0", "p0", "q1", "p1", "s", "h"], ["E"]))


__all__ = ["HamiltonianRule", "SymplecticEuler", "HamiltonianMidpoint", "LegendreRule",
           "HAMILTONIAN_RULES", "HamiltonianDiscretization", "LegendreDiscretization",
           "discrete_legendre"]
