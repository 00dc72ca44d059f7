"""The principle stage on the rotation group: the step residual of the discrete
Lagrange-d'Alembert(-Pontryagin) principle with variations on the group, dR_k = R_k eta_k^,
obtained by automatic differentiation of the discrete Lagrangian in the group increment
F_k = cay(f_k) (`dmoc.discrete.GroupDiscretization`). Both consumers use this residual: the
simulator solves it for the three Cayley coordinates f_k of each step; the optimizer
imposes it at every step (`dmoc.GroupOptimalControlProblem`) (docs/theory.md, "Rotations as group elements").
"""

import casadi as ca

from .._util import checks
from .._util.cache import BoundedCache
from .._util.layout import Layout
from ..discrete.group_discretization import GroupDiscretization
from ..mechanics.rotations import cayley, matrix_of, vector_of


class GroupStepResidual:
    """The step residual R of a rigid body on SO(3): the left-trivialized discrete
    Euler-Poincare (Lie-Poisson) equations with forces, one step of the Lie group
    variational integrator (Lee, Leok & McClamroch [1]_; with torques,
    the discrete Lagrange-d'Alembert principle as in [2]_).

    ``function(q0, p0, f, p1, u, h) -> r``: q0 (9) the rows of R_k, p0 and p1 (3 each)
    the body angular momenta Pi_k and Pi_{k+1}, f (3) the Cayley coordinates of the
    increment F_k = cay(f), u (n_u), h; r has 6 rows in the order of `row_layout`,
    ``"left"`` (3) and ``"right"`` (3). ``reconstruction(q0, f) -> q1`` gives the rows
    of R_{k+1} = R_k cay(f).

    Attributes
    ----------
    system : RigidBody
    n, n_controls : int
        3 (unknowns of a step, momenta) and the controls per step.
    inputs, row_layout : Layout
    rows : dict of slice
    function, reconstruction : casadi.Function
    key : tuple

    Notes
    -----
    With the variations dR_k = R_k eta_k^ (so that R_k -> R_k cay(eps eta_k), F_k ->
    cay(-eps eta_k) F_k and F_{k-1} -> F_{k-1} cay(eps eta_k)), D1 and D2 below are the
    left-trivialized derivatives of L_d(R_k, R_{k+1}, F_k) along eta_k and eta_{k+1},
    taken by automatic differentiation at eta = 0, and the rows are

        left  = p0 + D1 L_d + f_minus        (d/d eta_k)
        right = D2 L_d + f_plus - p1         (d/d eta_{k+1})

    the discrete Legendre transforms Pi_k = -D1 L_d - f_minus, Pi_{k+1} = D2 L_d + f_plus
    of the (+) form (37) written on the group; without constraints the (-) form (41) has
    the same rows. For L_d of `GroupDiscretization` they are, with M(R) the moment of U,
    M^ = dU/dR^T R - R^T dU/dR [1]_,

        h Pi_k^ + (h^2/2) M_k^ = F_k J_d - J_d F_k^T,
        Pi_{k+1} = F_k^T Pi_k + (h/2) F_k^T M_k + (h/2) M_{k+1}

    (with torques, f_minus and f_plus enter as (h/2) M does), which the tests check as a
    closed form. The left rows are solved for f; Pi_{k+1} is explicit.

    References
    ----------
    .. [1] T. Lee, M. Leok, N. H. McClamroch, "Lie group variational integrators for the
       full body problem", Comput. Methods Appl. Mech. Engrg. 196 (2007) 2907-2924.
    .. [2] M. Kobilarov, J. E. Marsden, "Discrete geometric optimal control on Lie
       groups", IEEE Trans. Robotics 27 (2011) 641-655.
    """

    def __init__(self, disc):
        checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
        self.system, self.key = disc.system, ("group", disc.key)
        self.n, self.n_controls = 3, disc.n_controls
        self.inputs = Layout([("q0", 9), ("p0", 3), ("f", 3), ("p1", 3),
                              ("u", self.n_controls), ("h", 1)])
        self.row_layout = Layout([("left", 3), ("right", 3)])
        self.rows = self.row_layout.slices()
        self.function, self.reconstruction = self._build(disc)

    def _build(self, disc):
        x = {name: ca.SX.sym(name, self.inputs.numel(name)) for name in self.inputs.blocks}
        R0, F, h = matrix_of(x["q0"]), cayley(x["f"]), x["h"]
        R1 = ca.mtimes(R0, F)
        eta0, eta1 = ca.SX.sym("eta0", 3), ca.SX.sym("eta1", 3)
        C0, C1 = cayley(eta0), cayley(eta1)
        varied = disc.discrete_lagrangian(vector_of(ca.mtimes(R0, C0)), vector_of(ca.mtimes(R1, C1)),
                                          vector_of(ca.mtimes([C0.T, F, C1])), h)
        eta, zero = ca.vertcat(eta0, eta1), ca.SX.zeros(6)
        D = ca.substitute(ca.gradient(varied, eta), eta, zero)
        f_minus, f_plus = disc.discrete_force(vector_of(R0), vector_of(R1), vector_of(F), x["u"], h)
        r = ca.cse(ca.vertcat(x["p0"] + D[:3] + f_minus, D[3:] + f_plus - x["p1"]))
        names = list(self.inputs.blocks)
        function = ca.Function("group_step_residual", [x[k] for k in names], [r], names, ["r"])
        reconstruction = ca.Function("reconstruction", [x["q0"], x["f"]], [vector_of(R1)],
                                     ["q0", "f"], ["q1"])
        return function, reconstruction

    def __call__(self, *args, **blocks):
        """Evaluate R positionally in the order of `inputs` or by block name; returns r."""
        if blocks:
            return self.function(**blocks)["r"]
        return self.function(*args)

    def __repr__(self):
        return f"GroupStepResidual({self.system!r})"


_RESIDUALS = BoundedCache(16, "group_residuals")


def group_step_residual(disc):
    """The GroupStepResidual of `disc`, built once per body (h is an input)."""
    checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
    return _RESIDUALS.get(disc.key, lambda: GroupStepResidual(disc))
