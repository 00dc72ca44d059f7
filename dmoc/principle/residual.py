"""The principle stage: the (+) and (-) discrete Lagrange-d'Alembert-Pontryagin action sums
(46)/(47), built as CasADi expressions with the momenta p_k as variables, and the ONE step
residual obtained from them by automatic differentiation under d'Alembert variations.
Both consumers, `simulate` and `OptimalControlProblem`, use this residual and nothing else.
Which sum, and where its multiplier sits, is the formulation's (`dmoc.formulations`).
"""

import casadi as ca

from .._util.cache import BoundedCache
from ..discrete import Discretization
from .formulations import as_formulation
from .._util.layout import Layout
from .one_step import check_one_step_map
from .parasitic import check_alternating_mode
from .._util import checks
from ..errors import InputTypeError


def action_sum(disc, variant, q, q_aux, p, s, h):
    """The discrete LDAP action sum (46) (variant "+") or (47) (variant "-").

    Parameters
    ----------
    disc : Discretization
    variant : {"+", "-"} or Formulation
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
    formulation = as_formulation(variant, disc)
    if not hasattr(formulation, "action_sum"):
        raise InputTypeError("`disc` must be a Lagrangian Discretization: action_sum is the sum (46)/(47) "
                             "of L_d; a Hamiltonian discretization differentiates (48)/(49).")
    return formulation.action_sum(disc.discrete_lagrangian, q, q_aux, p, s, h)


class StepResidual:
    """The step residual R of the (+) or (-) discrete LDAP principle, eqs. (37) and (41), or
    of the discrete Hamilton-d'Alembert principle, eqs. (39) and (43), for a Hamiltonian
    discretization (the rows of `dmoc.formulations.hamiltonian`).

    ``function(q0, p0, q1, p1, lam, s, u, h) -> r`` is one CasADi Function with named
    inputs (blocks and sizes in `inputs`) and r of size 2n + n_stages + n_lam, rows in the
    order of `row_layout`: ``"left"`` (n), ``"right"`` (n), ``"stage"`` (n_stages),
    ``"constraint"`` (n_lam = m per multiplier node). It depends on the system, the rule
    and the formulation only; the step h is an input, so discretizations at every h share
    it.

    Attributes
    ----------
    formulation : Formulation
    system : MechanicalSystem
    rule : QuadratureRule
    inputs, row_layout : Layout
        Named blocks of the inputs and of r; ``rows`` is ``row_layout.slices()``.
    function : casadi.Function
    discrete_force : casadi.Function or None
        A Lagrangian discretization's f_d, ``(q0, q1, s, u, h) -> (f_minus, f_plus,
        f_stage)``; None for a Hamiltonian one.

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

    and constraint = omega_d(q0, q1) (28). A(q) holds every constraint one-form of the
    system: the nonholonomic rows, then dg/dq of the holonomic constraints g(q) = 0, whose
    constraint rows are g(q1) itself (g(q0) is the previous step's), so g(q_k) = 0 holds
    exactly at every node (the SHAKE/RATTLE positions, docs/holonomic.md). A rule with interior nodes Q_j adds the stage
    rows dL_d/dQ_j + f_d^{s,j} - A(Q_j)^T lam_j (d'Alembert variations at the stages too),
    lam = (lam at the end node, lam_1, ...), and its moment constraints (docs/theory.md,
    "Stage rules"). The conditions from varying the p's, q_{k+1} =
    q_k^+ and q_k = q_{k+1}^-, are solved exactly by substitution. So lam_k is the
    multiplier at q_k for (+) and at q_{k+1} for (-); with the same data the (-) lam_k
    equals the (+) lam_{k+1}.
    """

    def __init__(self, disc, variant="+"):
        checks.instance("disc", disc, Discretization, "a Discretization")
        self.formulation = as_formulation(variant, disc)
        self.system, self.rule = disc.system, disc.rule
        self.discrete_force = getattr(disc, "discrete_force", None)     # None: Hamiltonian
        self.key = (disc.key, self.formulation)
        sys = disc.system
        self.n, self.m, self.n_stages = sys.n, sys.m, disc.n_stages
        self.n_lam, self.n_controls = disc.n_multipliers, disc.n_controls
        n, ns = self.n, self.n_stages
        self.inputs = Layout([("q0", n), ("p0", n), ("q1", n), ("p1", n), ("lam", self.n_lam),
                              ("s", ns), ("u", self.n_controls), ("h", 1)])
        self.row_layout = Layout([("left", n), ("right", n), ("stage", ns),
                                  ("constraint", self.n_lam)])
        self.rows = self.row_layout.slices()
        self.size = self.row_layout.size
        self.function = self._build(disc)

    @property
    def variant(self):
        """The formulation's name, ``"+"`` or ``"-"``."""
        return self.formulation.name

    def _build(self, disc):
        x = {name: ca.SX.sym(name, self.inputs.numel(name)) for name in self.inputs.blocks}
        left, right, stage = self.formulation.variational_rows(disc, x)
        rows = [left, right]
        A, m = self.system.constraint_matrix, self.m
        impulses = ca.vertsplit(x["lam"], list(range(0, self.n_lam + 1, m)) if m else [0, 0])
        node = self.formulation.multiplier_node
        rows[node] = rows[node] - ca.mtimes(A((x["q0"], x["q1"])[node]).T, impulses[0])
        if m and self.rule.has_interior_multipliers:    # d'Alembert variations at the stage nodes too
            interior = ca.vertsplit(self.rule.stage_configurations(x["s"], self.n), self.n)
            stage = stage - ca.vertcat(*[ca.mtimes(A(Q).T, lam) for Q, lam in zip(interior, impulses[1:])])
        r = ca.vertcat(rows[0], rows[1], stage,
                       disc.discrete_constraint(x["q0"], x["q1"], x["s"], x["h"]))
        r = ca.cse(r)     # AD of the sums repeats subexpressions: 294 -> 185 operations (lobatto3, knife edge)
        names = list(self.inputs.blocks)
        return ca.Function("step_residual", [x[k] for k in names], [r], names, ["r"])

    def __call__(self, *args, **blocks):
        """Evaluate R numerically or symbolically, positionally in the order of `inputs`
        or by block name; returns r."""
        if blocks:
            return self.function(**blocks)["r"]
        return self.function(*args)

    def __repr__(self):
        return (f"StepResidual({self.formulation!r}, n={self.n}, m={self.m}, "
                f"n_stages={self.n_stages})")


_RESIDUALS = BoundedCache(32, "residuals")


def step_residual(disc, variant="+"):
    """The StepResidual of `disc` for `variant`, built once per system, rule and formulation
    (whatever the step h: it is an input of the residual).

    Raises
    ------
    ValueError
        A Lagrangian discretization whose step equations do not determine q_{k+1}
        (`dmoc.principle.one_step`): both consumers refuse it with the same message.

    Warns
    -----
    ParasiticModeWarning
        A degenerate Lagrangian whose step equations under this rule have an alternating
        mode that grows along the motion (`dmoc.principle.parasitic`; the trapezoid on a
        nonlinear flow): both consumers warn alike.
    """
    checks.instance("disc", disc, Discretization, "a Discretization")
    formulation = as_formulation(variant, disc)
    if disc.family == "lagrangian":
        plus = as_formulation("+", disc)
        plus_residual = lambda: _RESIDUALS.get((disc.key, plus), lambda: StepResidual(disc, plus))  # noqa: E731
        check_one_step_map(disc, plus_residual)
        check_alternating_mode(disc, plus_residual)
    return _RESIDUALS.get((disc.key, formulation), lambda: StepResidual(disc, formulation))
