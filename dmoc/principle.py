"""The principle stage: the (+) and (-) discrete Lagrange-d'Alembert-Pontryagin action sums
(46)/(47), built as CasADi expressions with the momenta p_k as variables, and the ONE step
residual obtained from them by automatic differentiation under d'Alembert variations.
Both consumers, `simulate` and `OptimalControlProblem`, use this residual and nothing else.
"""

import functools

import casadi as ca

from . import _checks
from .discrete import Discretization

VARIANTS = ("+", "-")


def action_sum(disc, variant, q, q_aux, p, s, h):
    """The discrete LDAP action sum (46) (variant "+") or (47) (variant "-").

    Parameters
    ----------
    disc : Discretization
    variant : {"+", "-"}
    q : list of N+1 column expressions (n,)
        q_0 ... q_N.
    q_aux : list of N column expressions (n,)
        q_k^+ for (46), or q_{k+1}^- for (47).
    p : list of N column expressions (n,)
        p_1 ... p_N for (46), or p_0 ... p_{N-1} for (47): the multipliers of the discrete
        second-order curve conditions q_{k+1} = q_k^+ and q_k = q_{k+1}^-.
    s : list of N column expressions (n_stages,)
        Stage unknowns of each step (empty for stage-free rules).
    h : scalar expression

    Returns
    -------
    casadi.SX
        (46): sum_k L_d(q_k, q_k^+) + p_{k+1} . (q_{k+1} - q_k^+)
        (47): sum_k L_d(q_{k+1}^-, q_{k+1}) - p_k . (q_k - q_{k+1}^-)
    """
    L_d = disc.discrete_lagrangian
    if variant == "+":
        terms = [L_d(q[k], q_aux[k], s[k], h) + ca.dot(p[k], q[k + 1] - q_aux[k])
                 for k in range(len(q_aux))]
    else:
        terms = [L_d(q_aux[k], q[k + 1], s[k], h) - ca.dot(p[k], q[k] - q_aux[k])
                 for k in range(len(q_aux))]
    return sum(terms)


class StepResidual:
    """The step residual R of the (+) or (-) discrete LDAP principle, eqs. (37) and (41).

    ``function(q0, p0, q1, p1, lam, s, u, h) -> r`` is one CasADi Function, r of size
    2n + n_stages + m, with rows in this order (``rows`` maps names to slices):

    ``"left"`` (n), ``"right"`` (n), ``"stage"`` (n_stages), ``"constraint"`` (m).

    Notes
    -----
    Obtained by differentiating a two-step window of `action_sum` and adding the discrete
    virtual work of the forces, f_d^- . dq_k + f_d^+ . dq_k^+; the d'Alembert node (q_k
    in (+), q_{k+1} in (-)) has variations in Delta_Q only, so its row is projected by a
    multiplier on A(q) (never on the gradient of omega_d, which would be vakonomic):

    (+): left  = p0 + D1 L_d(q0, q1) + f_d^- - A(q0)^T lam     (d/dq_k)
         right = D2 L_d(q0, q1) + f_d^+ - p1                   (d/dq_k^+)
    (-): left  = p0 + D1 L_d(q0, q1) + f_d^-                   (d/dq_{k+1}^-)
         right = D2 L_d(q0, q1) + f_d^+ - p1 - A(q1)^T lam     (d/dq_{k+1})

    and constraint = omega_d(q0, q1) (28). The conditions from varying the p's, q_{k+1} =
    q_k^+ and q_k = q_{k+1}^-, are solved exactly by substitution. So lam_k is the
    multiplier at q_k for (+) and at q_{k+1} for (-); with the same data the (-) lam_k
    equals the (+) lam_{k+1}.
    """

    def __init__(self, disc, variant="+"):
        if not isinstance(disc, Discretization):
            raise TypeError(f"`disc` must be a Discretization; got {type(disc).__name__}.")
        self.disc = disc
        self.variant = _checks.choice("variant", variant, VARIANTS)
        sys = disc.system
        self.n, self.m, self.n_u, self.n_stages = sys.n, sys.m, sys.n_u, disc.n_stages
        n, ns = self.n, self.n_stages
        self.rows = {"left": slice(0, n), "right": slice(n, 2 * n),
                     "stage": slice(2 * n, 2 * n + ns),
                     "constraint": slice(2 * n + ns, 2 * n + ns + self.m)}
        self.size = 2 * n + ns + self.m
        self.function = self._build()

    def _build(self):
        n, m, ns, sys, disc = self.n, self.m, self.n_stages, self.disc.system, self.disc
        sym = {name: ca.SX.sym(name, n) for name in ("q0", "p0", "q1", "p1", "aux", "a", "b", "c")}
        lam, s, s_other = ca.SX.sym("lam", m), ca.SX.sym("s", ns), ca.SX.sym("s_other", ns)
        u, h = ca.SX.sym("u", sys.n_u), ca.SX.sym("h")
        q0, p0, q1, p1, aux = (sym[k] for k in ("q0", "p0", "q1", "p1", "aux"))
        if self.variant == "+":   # window: steps k-1 and k; a = q_{k-1}, b = q_{k-1}^+
            S = action_sum(disc, "+", [sym["a"], q0, q1], [sym["b"], aux], [p0, p1],
                           [s_other, s], h)
            f_minus, f_plus, f_stage = disc.discrete_force(q0, aux, s, u, h)
            left = ca.gradient(S, q0) + f_minus - ca.mtimes(sys.constraint_matrix(q0).T, lam)
            right = ca.gradient(S, aux) + f_plus
        else:                     # window: steps k and k+1; b = q_{k+2}^-, c = q_{k+2}
            S = action_sum(disc, "-", [q0, q1, sym["c"]], [aux, sym["b"]], [p0, p1],
                           [s, s_other], h)
            f_minus, f_plus, f_stage = disc.discrete_force(aux, q1, s, u, h)
            left = ca.gradient(S, aux) + f_minus
            right = ca.gradient(S, q1) + f_plus - ca.mtimes(sys.constraint_matrix(q1).T, lam)
        stage = ca.gradient(S, s) + f_stage if ns else ca.SX(0, 1)
        # Stationarity under delta p: the discrete second-order curve condition.
        curve = ca.gradient(S, p1 if self.variant == "+" else p0)
        solved_aux = q1 if self.variant == "+" else q0
        r = ca.vertcat(left, right, stage, disc.discrete_constraint(q0, q1, h))
        r = ca.substitute(r, aux, solved_aux)
        _check_window(r, curve, aux, solved_aux, [sym["a"], sym["b"], sym["c"], s_other])
        return ca.Function("step_residual", [q0, p0, q1, p1, lam, s, u, h], [r],
                           ["q0", "p0", "q1", "p1", "lam", "s", "u", "h"], ["r"])

    def __call__(self, q0, p0, q1, p1, lam, s, u, h):
        """Evaluate R numerically or symbolically; see `function`."""
        return self.function(q0, p0, q1, p1, lam, s, u, h)

    def __repr__(self):
        return f"StepResidual(variant={self.variant!r}, n={self.n}, m={self.m}, n_stages={self.n_stages})"


def _check_window(r, curve, aux, solved_aux, others):
    """Internal invariant: the curve condition is solved by the substitution, and the
    residual of step k does not involve the neighbouring step's variables."""
    if not ca.simplify(ca.substitute(curve, aux, solved_aux)).is_zero():
        raise RuntimeError("the discrete second-order curve condition was not eliminated")
    if any(ca.depends_on(r, x) for x in others if x.numel()):
        raise RuntimeError("the step residual depends on a neighbouring step")


def step_residual(disc, variant="+"):
    """The StepResidual of `disc` for `variant`, built once per discretization and variant."""
    return _cached_residual(disc, _checks.choice("variant", variant, VARIANTS))


@functools.lru_cache(maxsize=64)
def _cached_residual(disc, variant):
    return StepResidual(disc, variant)
