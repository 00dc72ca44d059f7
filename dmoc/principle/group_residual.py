"""The principle stage on SO(3) x R^n_x: the step residual of the discrete
Lagrange-d'Alembert(-Pontryagin) principle with variations on the group, dR_k = R_k eta_k^,
and on the vector coordinates, obtained by automatic differentiation of the discrete
Lagrangian in the group increment F_k = cay(f_k) and the vector increment
(`dmoc.discrete.GroupDiscretization`), with the constraint one-forms as multiplier rows.
Both consumers use this residual: the simulator solves it for the Cayley coordinates f_k,
the vector increment and the multipliers of each step; the optimizer imposes it at every
step (`dmoc.GroupOptimalControlProblem`) (docs/theory.md, "Rotations as group elements").
"""

import functools

import casadi as ca

from .._util import checks
from .._util.cache import BoundedCache
from .._util.layout import Layout
from .._util.typed_ops import minus, plus
from ..discrete.group_discretization import GroupDiscretization
from ..mechanics.rotations import cayley, hat, matrix_of, vector_of


class GroupStepResidual:
    """The step residual R of a rigid body on SO(3) x R^n_x: the left-trivialized discrete
    Euler-Poincare (Lie-Poisson) equations with forces, one step of the Lie group
    variational integrator (Lee, Leok & McClamroch [1]_; with torques, the discrete
    Lagrange-d'Alembert principle as in [2]_), with the constraint one-forms entering as
    the (+) form (37) of [3]_ does on R^n.

    ``function(q0, p0, f, p1, lam, u, h) -> r``: q0 (9 + n_x) the rows of R_k then x_k,
    p0 and p1 (n = 3 + n_x each) the momenta (Pi_k, p_x,k) and (Pi_{k+1}, p_x,k+1), f (n)
    the Cayley coordinates of the increment F_k = cay(f_{1:3}) followed by the vector
    increment dx_k = x_{k+1} - x_k, lam (m) the multipliers, u (n_u), h; r has 2n + m
    rows in the order of `row_layout`, ``"left"`` (n), ``"right"`` (n) and
    ``"constraint"`` (m). ``reconstruction(q0, f) -> q1`` gives q_{k+1} = (the rows of
    R_k cay(f_{1:3}), x_k + dx_k), and ``stepped(q0, p0, f, p1, lam, u, h) -> (r, q1)``
    both from one expression graph: the rows read R_{k+1} = R_k cay(f_{1:3}) too, so a
    consumer that needs both (the NLP's step term, the simulator's step) inlines them once
    (the rolling ball's step term: 318 operations instead of 397 with the two Functions
    called apart, and its derivatives smaller alike).

    Attributes
    ----------
    system : RigidBody or FloatingBaseRobot
    n, m, n_controls : int
        3 + n_x (momenta and increments), constraint rows, controls per step.
    inputs, row_layout : Layout
    rows : dict of slice
    stepped : casadi.Function
    function, reconstruction : casadi.Function
        Made from `stepped` on first use.
    key : tuple

    Notes
    -----
    With the variations dR_k = R_k eta_k^ (so that R_k -> R_k cay(eps eta_k), F_k ->
    cay(-eps eta_k) F_k and F_{k-1} -> F_{k-1} cay(eps eta_k)) and dx_k, D1 and D2 below
    are the left-trivialized derivatives of L_d(q_k, q_{k+1}, F_k) along (eta_k, dx_k) and
    (eta_{k+1}, dx_{k+1}), taken by automatic differentiation at zero, and the rows are

        left       = p0 + D1 L_d + f_minus - A(q_k)^T lam      (d/d(eta_k, dx_k))
        right      = D2 L_d + f_plus - p1                       (d/d(eta_{k+1}, dx_{k+1}))
        constraint = omega_d(q_k, q_{k+1})                      (the discrete one-forms)

    the discrete Legendre transforms of the (+) form (37) [3]_ written on the group, the
    multiplier on the one-forms A at the d'Alembert node q_k, never on the gradient of
    omega_d. Without constraints the (-) form (41) has the same rows. For L_d of
    `GroupDiscretization` and n_x = m = 0 they are, with M(R) the moment of U,
    M^ = dU/dR^T R - R^T dU/dR [1]_,

        h Pi_k^ + (h^2/2) M_k^ = F_k J_d - J_d F_k^T,
        Pi_{k+1} = F_k^T Pi_k + (h/2) F_k^T M_k + (h/2) M_{k+1}

    (with torques, f_minus and f_plus enter as (h/2) M does), which the tests check as a
    closed form. The left and constraint rows are solved for (f, lam); p1 is explicit.

    References
    ----------
    .. [1] T. Lee, M. Leok, N. H. McClamroch, "Lie group variational integrators for the
       full body problem", Comput. Methods Appl. Mech. Engrg. 196 (2007) 2907-2924.
    .. [2] M. Kobilarov, J. E. Marsden, "Discrete geometric optimal control on Lie
       groups", IEEE Trans. Robotics 27 (2011) 641-655.
    .. [3] M. Leok, T. Ohsawa, "Variational and geometric structures of discrete Dirac
       mechanics", Found. Comput. Math. 11 (2011) 529-562.
    """

    def __init__(self, disc):
        checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
        self.system, self.key = disc.system, ("group", disc.key)
        self.n, self.m, self.n_controls = disc.system.n, disc.system.m, disc.n_controls
        n_x = self.n - 3
        self.inputs = Layout([("q0", 9 + n_x), ("p0", self.n), ("f", self.n), ("p1", self.n),
                              ("lam", self.m), ("u", self.n_controls), ("h", 1)])
        self.row_layout = Layout([("left", self.n), ("right", self.n), ("constraint", self.m)])
        self.rows = self.row_layout.slices()
        self.stepped = self._build(disc)

    @functools.cached_property
    def function(self):
        """``(q0, p0, f, p1, lam, u, h) -> r``, the rows of `stepped` (made on first use: the
        NLP and the simulator call `stepped`)."""
        x = self.stepped.sx_in()
        names = list(self.inputs.blocks)
        return ca.Function("group_step_residual", x, [self.stepped(*x)[0]], names, ["r"])

    @functools.cached_property
    def reconstruction(self):
        """``(q0, f) -> q1``, the q_{k+1} of `stepped` (made on first use)."""
        x = self.stepped.sx_in()
        return ca.Function("reconstruction", [x[0], x[2]], [self.stepped(*x)[1]], ["q0", "f"], ["q1"])

    def _build(self, disc):
        x = self.inputs.split(ca.SX.sym("x", self.inputs.size))     # one symbol, split
        q0, h = x["q0"], x["h"]
        q1, F9, D1, D2 = trivialized_derivatives(disc, q0, x["f"], h)
        f_minus, f_plus = disc.discrete_force(q0, q1, F9, x["u"], h)
        A0 = self.system.constraint_matrix(q0)
        # no common-subexpression pass (0.5 ms of a 1.4 ms build): the NLP's derivatives of
        # r cost as much without it (16 more instructions of 256) and the compiled step
        # makes its own (`dmoc.simulation.fast_path`)
        r = ca.vertcat(minus(plus(plus(x["p0"], D1), f_minus), ca.mtimes(A0.T, x["lam"])),
                       minus(plus(D2, f_plus), x["p1"]),
                       disc.discrete_constraint(q0, q1, F9, h))
        names = list(self.inputs.blocks)
        return ca.Function("stepped_residual", [x[k] for k in names], [r, q1], names, ["r", "q1"])

    def __call__(self, *args, **blocks):
        """Evaluate R positionally in the order of `inputs` or by block name; returns r."""
        if blocks:
            return self.function(**blocks)["r"]
        return self.function(*args)

    def __repr__(self):
        return f"GroupStepResidual({self.system!r})"


def trivialized_derivatives(disc, q0, f, h):
    """The step from q0 by the increment f and the left-trivialized derivatives of its
    discrete Lagrangian, as CasADi expressions of the symbols `q0` (9 + n_x), `f` (3 + n_x)
    and `h`: (q1, F9, D1, D2) with q1 = (the rows of R_0 cay(f_{1:3}), x_0 + f_{4:}), F9 the
    9 entries of F = cay(f_{1:3}), and D1, D2 (3 + n_x each) the derivatives of
    L_d(q0, q1, F) along R_0 -> R_0 cay(eps eta_0), x_0 -> x_0 + eps dx_0 and along
    R_1 -> R_1 cay(eps eta_1), x_1 -> x_1 + eps dx_1 at eps = 0 (F varying with them as
    cay(-eps eta_0) F cay(eps eta_1)): D_i L_d = (T_e L_{R_i})^* d_i L_d on the rotation,
    the ordinary gradient on x. Only the curves' first order enters a derivative at
    eps = 0, so they are differentiated as R_i (I + eps eta_i^) (cay(eps eta) = I +
    eps eta^ + O(eps^2)), F as (I - eps eta_0^) F (I + eps eta_1^): the same D_i from
    fewer operations."""
    n = disc.system.n
    x0 = q0[9:]
    x1 = plus(x0, f[3:])
    eta0, eta1 = ca.SX.sym("eta0", n), ca.SX.sym("eta1", n)
    R1, F9, start, end, increment = _varied_rotations()(q0[:9], f[:3], eta0[:3], eta1[:3])
    varied = disc.discrete_lagrangian(ca.vertcat(start, plus(x0, eta0[3:])),
                                      ca.vertcat(end, plus(x1, eta1[3:])), increment, h)
    eta = ca.vertcat(eta0, eta1)
    D = ca.substitute(ca.gradient(varied, eta), eta, ca.SX.zeros(2 * n))
    return ca.vertcat(R1, x1), F9, D[:n], D[n:]


@functools.cache
def _varied_rotations():
    """The Function (R_0, f, eta_0, eta_1) -> (R_1, F, R_0 C_0, R_1 C_1, C_0^T F C_1), each
    matrix as its 9 entries row after row (`vector_of`): F = cay(f), R_1 = R_0 F and
    C_i = I + eta_i^ (`trivialized_derivatives`). Fixed (no body's data), made once for
    the process: its call inlines the same nodes as the products made op by op from
    Python, at a fraction of their cost."""
    R0, f = ca.SX.sym("R0", 9), ca.SX.sym("f", 3)
    eta0, eta1 = ca.SX.sym("eta0", 3), ca.SX.sym("eta1", 3)
    F, R = cayley(f), matrix_of(R0)
    R1 = ca.mtimes(R, F)
    C0, C1 = (ca.DM.eye(3) + hat(eta) for eta in (eta0, eta1))
    return ca.Function("varied_rotations", [R0, f, eta0, eta1],
                       [vector_of(R1), vector_of(F), vector_of(ca.mtimes(R, C0)),
                        vector_of(ca.mtimes(R1, C1)), vector_of(ca.mtimes([C0.T, F, C1]))])


_RESIDUALS = BoundedCache(16, "group_residuals")


def group_step_residual(disc):
    """The GroupStepResidual of `disc`, built once per body (h is an input)."""
    checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
    return _RESIDUALS.get(disc.key, lambda: GroupStepResidual(disc))
