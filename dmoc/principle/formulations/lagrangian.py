"""The Lagrangian forms: the implicit discrete Lagrange-d'Alembert equations (37) and (41),
obtained by differentiating the discrete Lagrange-d'Alembert-Pontryagin sums (46) and (47)
over a two-step window, the curve condition solved by substitution; their Dirac
differentials D+-L_d (Section 5).
"""

from dataclasses import dataclass

import casadi as ca

from ..._util import typed_ops
from ..._util.layout import step_symbols
from ..tulczyjew import kappa_inverse
from .base import MinusForm, PlusForm


@dataclass(frozen=True)
class Window:
    """Two consecutive steps of an action sum, as a Lagrangian form differentiates them.

    Attributes
    ----------
    action : casadi.SX
        The sum over the window.
    ends : (casadi.SX, casadi.SX)
        The variables whose variations give the step's "left" and "right" rows.
    curve : casadi.SX
        The momentum whose variation gives the discrete second-order curve condition.
    aux, solved : casadi.SX
        The auxiliary configuration and its value from the curve condition.
    neighbours : tuple of casadi.SX
        Variables of the other step of the window, which the residual must not involve.
    """

    action: object
    ends: tuple
    curve: object
    aux: object
    solved: object
    neighbours: tuple


class LagrangianForm:
    """What the two Lagrangian forms share: rows from a window of their sum, D+-L_d."""

    explicit = "p1"
    momentum_rows = ("left", "right", "stage")     # gradients of the sum in q and the stages

    def window(self, discrete_lagrangian, sym):
        """The Window of the action sum around step k from the symbols `sym` (a dict:
        q0, p0, q1, p1, aux, a, b, c of shape (n,), s, s_other of shape (n_stages,), h)."""
        raise NotImplementedError

    def variational_rows(self, disc, x):
        """(left, right, stage): the gradients of the window of (46)/(47) in the step's two
        end variables and its stages, plus the discrete virtual work f_d^-, f_d^+, f_d^s;
        the curve condition q_{k+1} = q_k^+ (q_k = q_{k+1}^-) solved by substitution."""
        n, ns = x["q0"].numel(), x["s"].numel()
        sym = {**x, **{k: ca.SX.sym(k, n) for k in ("aux", "a", "b", "c")},
               "s_other": ca.SX.sym("s_other", ns)}
        window = self.window(disc.discrete_lagrangian, sym)
        x_minus, x_plus = window.ends
        f_minus, f_plus, f_stage = disc.discrete_force(x_minus, x_plus, x["s"], x["u"], x["h"])
        S = window.action
        # one reverse sweep for the three gradients, one substitution for the three rows
        gradient = ca.gradient(S, ca.vertcat(x_minus, x_plus, x["s"]))
        gradients = ca.vertsplit(gradient, [0, n, 2 * n, 2 * n + ns])
        rows = [typed_ops.plus(d, f) for d, f in zip(gradients, (f_minus, f_plus, f_stage))]
        rows = ca.substitute(rows, [window.aux], [window.solved])
        _check_window(ca.vertcat(*rows), ca.gradient(S, window.curve), window)
        return rows

    def dirac_differential(self, disc):
        """D+L_d = gamma_d+ o dL_d or D-L_d = gamma_d- o dL_d, the forces entering dL_d as
        D1 L_d + f_d^- and D2 L_d + f_d^+: "+" gives (q0, D2 L_d + f^+, -D1 L_d - f^-, q1),
        "-" gives (-D1 L_d - f^-, q1, -q0, -D2 L_d - f^+)."""
        x = _step_symbols(disc)
        L_d = disc.discrete_lagrangian(x["q0"], x["q1"], x["s"], x["h"])
        f_minus, f_plus, _ = disc.discrete_force(x["q0"], x["q1"], x["s"], x["u"], x["h"])
        dL_d = (x["q0"], x["q1"], ca.gradient(L_d, x["q0"]) + f_minus, ca.gradient(L_d, x["q1"]) + f_plus)
        return _differential_function(self, x, self.omega_flat(*kappa_inverse(dL_d)))


class LagrangianPlus(LagrangianForm, PlusForm):
    """The (+) Lagrangian form: (37) from the discrete LDAP sum (46), D^{d+} (36)."""

    def action_sum(self, discrete_lagrangian, q, q_aux, p, s, h):
        """(46): sum_k L_d(q_k, q_k^+) + p_{k+1} . (q_{k+1} - q_k^+)."""
        return typed_ops.total(
            typed_ops.plus(discrete_lagrangian(q[k], q_aux[k], s[k], h),
                           ca.dot(p[k], typed_ops.minus(q[k + 1], q_aux[k])))
            for k in range(len(q_aux)))

    def window(self, discrete_lagrangian, sym):
        # steps k-1 and k; a = q_{k-1}, b = q_{k-1}^+, aux = q_k^+
        action = self.action_sum(discrete_lagrangian, [sym["a"], sym["q0"], sym["q1"]],
                                 [sym["b"], sym["aux"]], [sym["p0"], sym["p1"]],
                                 [sym["s_other"], sym["s"]], sym["h"])
        return Window(action, (sym["q0"], sym["aux"]), sym["p1"], sym["aux"], sym["q1"],
                      (sym["a"], sym["b"], sym["c"], sym["s_other"]))


class LagrangianMinus(LagrangianForm, MinusForm):
    """The (-) Lagrangian form: (41) from the discrete LDAP sum (47), D^{d-} (40)."""

    def action_sum(self, discrete_lagrangian, q, q_aux, p, s, h):
        """(47): sum_k L_d(q_{k+1}^-, q_{k+1}) - p_k . (q_k - q_{k+1}^-)."""
        return typed_ops.total(
            typed_ops.minus(discrete_lagrangian(q_aux[k], q[k + 1], s[k], h),
                            ca.dot(p[k], typed_ops.minus(q[k], q_aux[k])))
            for k in range(len(q_aux)))

    def window(self, discrete_lagrangian, sym):
        # steps k and k+1; aux = q_{k+1}^-, b = q_{k+2}^-, c = q_{k+2}
        action = self.action_sum(discrete_lagrangian, [sym["q0"], sym["q1"], sym["c"]],
                                 [sym["aux"], sym["b"]], [sym["p0"], sym["p1"]],
                                 [sym["s"], sym["s_other"]], sym["h"])
        return Window(action, (sym["aux"], sym["q1"]), sym["p0"], sym["aux"], sym["q0"],
                      (sym["a"], sym["b"], sym["c"], sym["s_other"]))


def _check_window(r, curve, window):
    """Internal invariant: the curve condition is solved by the substitution, and the
    residual of step k does not involve the neighbouring step's variables."""
    if not ca.simplify(ca.substitute(curve, window.aux, window.solved)).is_zero():
        raise RuntimeError("the discrete second-order curve condition was not eliminated")
    if ca.depends_on(r, ca.vertcat(*window.neighbours)):       # one test for them all
        raise RuntimeError("the step residual depends on a neighbouring step")


def _step_symbols(disc):
    """The step symbols (`dmoc._util.layout.step_symbols`) of the discretization `disc`."""
    return step_symbols(disc.system.n, disc.n_stages, disc.n_controls)


def _differential_function(formulation, x, components):
    names = ["q0", "p0", "q1", "p1", "s", "u", "h"]
    return ca.Function("dirac_differential_" + formulation.label, [x[k] for k in names],
                       list(components), names, ["c0", "c1", "c2", "c3"])
