"""The Jacobian dg/dy of the simulator's step equations (`dmoc.simulation.stepper`), which
the fast path's chord factorizes (`dmoc.simulation.fast_path`): by automatic differentiation
of the rows, or, for a system that gives its Lagrangian's second variation (a fixed-base
`RobotSystem`, `second_variation`) under the midpoint rule, from it, O(1) operations per
entry where the automatic one costs about 0.7 n sweeps through the rows.
"""

import casadi as ca

from ..discrete.quadrature_rules import Midpoint
from ..principle.formulations.lagrangian import LagrangianForm


def step_jacobian(stepper, g, y, params, automatic=None):
    """dg/dy of the step equations g(y, params) of `stepper` (a `DiracStepper`), SX.

    For the left rows of the midpoint rule, g = p_k + D1 L_d(q_k, q_k + dq) + f_d^-, L_d =
    h L(q_bar, v_bar), q_bar = q_k + dq/2, v_bar = dq/h (eq. (37) with no multipliers), the
    unknowns y = dq, and

        dg/dy = h/4 L_qq + 1/2 (L_qv - L_qv^T) - L_vv/h + d f_d^-/d dq,

    the first four terms L's second variation at (q_bar, v_bar) along a = (h/2, -1) and b =
    (1/2, 1/h) (the system's ``second_variation(q, v, a, b)``; D2 D1 L_d), the force's
    term by automatic differentiation (it is linear in n). Every other step, and a system
    whose ``second_variation`` gives None, takes ``ca.jacobian``.

    Parameters
    ----------
    stepper : DiracStepper
    g, y : casadi.SX, shape (unknowns.size, 1)
        The step equations (``stepper.equations(y, params)[0]``) and the unknowns' symbols.
    params : casadi.SX, shape (2 n + n_controls + 1, 1)
        (q_k, p_k', u, h), as ``stepper.symbols`` gives them.
    automatic : casadi.SX, optional
        ``ca.jacobian(g, y)`` when the caller has built it (`fast_path.step_rows`), what
        the steps without a second variation take; built here when None.

    Returns
    -------
    casadi.SX, shape (unknowns.size, unknowns.size)
    """
    R = stepper.residual
    n, variation = R.n, getattr(R.system, "second_variation", None)
    q0, u, h = params[:n], params[2 * n:2 * n + R.n_controls], params[-1]
    W = None
    if (variation is not None and isinstance(R.rule, Midpoint) and isinstance(R.formulation, LagrangianForm)
            and not R.n_lam and y.numel() == n):
        (_, q_bar, v_bar, _), = R.rule.samples(q0, q0 + y, ca.SX(0, 1), h)   # L_d's own midpoint
        W = variation(q_bar, v_bar, (h / 2, -1.0), (0.5, 1 / h))
    if W is None:
        return ca.jacobian(g, y) if automatic is None else automatic
    return W + ca.jacobian(R.discrete_force(q0, q0 + y, ca.SX(0, 1), u, h)[0], y)
