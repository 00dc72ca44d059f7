"""The Hamiltonian forms: the implicit discrete Hamilton equations (39) and (43), obtained by
differentiating the discrete Hamilton-d'Alembert sums (48) and (49) in phase space, with
the discrete virtual work of the forces; their Dirac differentials dH_d+- of (38)/(42).

The step's generating function may carry stage unknowns s (an extremum over internal
values, as a Galerkin H_d does); their stationarity rows are the residual's "stage" rows,
and the envelope theorem makes D1, D2 at fixed stages the derivatives of H_d.
"""

import casadi as ca

from .base import MinusForm, PlusForm
from .lagrangian import _differential_function, _step_symbols


class HamiltonianPlus(PlusForm):
    """The (+) Hamiltonian form: (39) from (48), D^{d+} (38), with a right discrete
    Hamiltonian H_d+(q_k, p_{k+1}).

    Rows: left = p_k - D1 H_d+ + f_d^- (d/dq_k of (48), the multiplier added at q_k);
    right = D2 H_d+ - q_{k+1} (d/dp_{k+1}: q_{k+1} is explicit); stage = -dH_d+/ds + f_d^s.
    """

    explicit = "q1"
    momentum_rows = ("left",)

    def variational_rows(self, disc, x):
        H = disc.right_hamiltonian(x["q0"], x["p1"], x["s"], x["h"])
        f_q0, f_stage = disc.right_force(x["q0"], x["p1"], x["s"], x["u"], x["h"])
        stage = -ca.gradient(H, x["s"]) + f_stage if x["s"].numel() else ca.SX(0, 1)
        return (x["p0"] - ca.gradient(H, x["q0"]) + f_q0, ca.gradient(H, x["p1"]) - x["q1"], stage)

    def dirac_differential(self, disc):
        """dH_d+ at (q_k, p_{k+1}) with the force: (q0, p1, D1 H_d+ - f_d^-, D2 H_d+)."""
        x = _step_symbols(disc)
        H = disc.right_hamiltonian(x["q0"], x["p1"], x["s"], x["h"])
        f_q0, _ = disc.right_force(x["q0"], x["p1"], x["s"], x["u"], x["h"])
        return _differential_function(self, x, (x["q0"], x["p1"], ca.gradient(H, x["q0"]) - f_q0,
                                                ca.gradient(H, x["p1"])))


class HamiltonianMinus(MinusForm):
    """The (-) Hamiltonian form: (43) from (49), D^{d-} (42), with a left discrete
    Hamiltonian H_d-(p_k, q_{k+1}).

    Rows: left = -q_k - D1 H_d- (d/dp_k); right = -D2 H_d- + f_d^+ - p_{k+1} (d/dq_{k+1}:
    p_{k+1} is explicit, the multiplier added at q_{k+1}); stage = -dH_d-/ds + f_d^s.
    """

    momentum_rows = ("right",)

    def variational_rows(self, disc, x):
        H = disc.left_hamiltonian(x["p0"], x["q1"], x["s"], x["h"])
        f_q1, f_stage = disc.left_force(x["p0"], x["q1"], x["s"], x["u"], x["h"])
        stage = -ca.gradient(H, x["s"]) + f_stage if x["s"].numel() else ca.SX(0, 1)
        return (-x["q0"] - ca.gradient(H, x["p0"]), -ca.gradient(H, x["q1"]) + f_q1 - x["p1"], stage)

    def dirac_differential(self, disc):
        """dH_d- at (p_k, q_{k+1}) with the force: (p0, q1, D1 H_d-, D2 H_d- - f_d^+)."""
        x = _step_symbols(disc)
        H = disc.left_hamiltonian(x["p0"], x["q1"], x["s"], x["h"])
        f_q1, _ = disc.left_force(x["p0"], x["q1"], x["s"], x["u"], x["h"])
        return _differential_function(self, x, (x["p0"], x["q1"], ca.gradient(H, x["p0"]),
                                                ca.gradient(H, x["q1"]) - f_q1))
