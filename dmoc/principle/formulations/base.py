"""The conventions every formulation shares, by sign: where the d'Alembert multiplier sits,
the impulses at the start and the end, the momentum boundary rows of the optimizer, how a
solved step fills a Trajectory and which Dirac structure it lies in ((34)/(36) and
(38) for "+", (35)/(40) and (42) for "-"). The Lagrangian and Hamiltonian forms add the
action sum they differentiate (`dmoc.formulations.lagrangian`, `.hamiltonian`).
"""

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..._util.cache import BoundedCache
from ..tulczyjew import omega_flat_minus, omega_flat_plus

_CONDITIONS = BoundedCache(64, "momentum_conditions")      # momentum boundary rows by (system key, formulation)


@dataclass(frozen=True)
class Formulation:
    """A form of the implicit discrete Lagrange-d'Alembert equations; see the subclasses.

    Attributes
    ----------
    name : str
        ``"+"`` or ``"-"``: the string accepted at the public API, stored as
        ``Trajectory.variant``.
    label : str
        A word for file and Function names (``"plus"``, ``"minus"``).
    multiplier_node : int
        0 if lam_k multiplies A(q_k) in the "left" row, 1 if A(q_{k+1}) in the "right" row.
    start_impulse, end_impulse : int
        Sign of the boundary impulse A(q)^T mu at q_0, A(q)^T nu at q_N in the momentum
        boundary rows (0: none; see `momentum_conditions`).
    end_momentum_determined : bool
        Whether a simulation's p_N equals the optimizer's (False when the impulse at q_N,
        which no N-step simulation can know, is part of p_N).
    impulse_side : float
        p_k of this form is the momentum before (+: -1/2) or after (-: +1/2) the impulse
        A(q_k)^T iota_k at q_k; p_k + impulse_side A(q_k)^T iota_k is the mean of the two
        (`dmoc.diagnostics.mean_momenta`).
    explicit : {"p1", "q1"}
        The end variable the step's "right" rows give explicitly, as (...) - p1 or
        (...) - q1; the simulator solves the other rows for the rest.
    momentum_rows : tuple of str
        The residual's row blocks in units of momentum (the rest are in units of
        configuration or velocity): the optimizer divides them by the inertia
        (`dmoc.optimal_control.nlp.scaling`).
    """

    name = None
    label = None
    multiplier_node = None
    start_impulse = 0
    end_impulse = 0
    end_momentum_determined = True
    impulse_side = None

    explicit = "p1"
    momentum_rows = ()

    def variational_rows(self, disc, x):
        """The rows (left, right, stage) of step k from the stationarity of this form's sum,
        forces included and d'Alembert multipliers not yet (the principle adds those and
        the constraint rows); `x` holds the residual's input symbols by block name."""
        raise NotImplementedError

    def dirac_differential(self, disc):
        """The Dirac differential of the form's generating function at a step, with forces,
        as a Function ``(q0, p0, q1, p1, s, u, h) -> (c0, c1, c2, c3)``: a point of
        T*(Q x Q*) for "+" or of T*(Q* x Q) for "-", compared with `omega_flat`."""
        raise NotImplementedError

    def step_momentum(self, system, q0, p_carried, nu):
        """(p_k, lam_k) of the step equations from the momentum carried into step k and the
        multipliers `nu` the simulator solves for: the impulse at q_k (first m rows), then
        those at the interior nodes."""
        raise NotImplementedError

    def node_impulses(self, lam, mu, m):
        """The impulses iota_k at q_0 ... q_{N-1}, shape (N, m), from a Trajectory's
        `lam` (N, n_lam) and `mu` (m,)."""
        raise NotImplementedError

    def trajectory_blocks(self, p_carried, p_used, nu, m):
        """(p, lam, mu) of a Trajectory from a simulation's per-step blocks: `p_carried`
        (..., N+1, n) carried momenta, `p_used` (..., N, n) the p_k the step equations
        used, `nu` (..., N, n_lam) the multipliers solved for (the first m at q_k); the
        leading axes, if any, those of runs in lockstep (`conclude_group`)."""
        raise NotImplementedError

    def momentum_conditions(self, system):
        """The optimizer's momentum boundary rows.

        Returns
        -------
        start, end : casadi.Function
            ``start(q, p, v, mu) -> r`` and ``end(q, p, v, nu) -> r``, r of shape (n,):
            p - dL/dv(q, v) + start_impulse A(q)^T mu at q_0 and
            p - dL/dv(q, v) + end_impulse A(q)^T nu at q_N, A(q) holding every constraint
            one-form (dg/dq of holonomic constraints included).
        m_start, m_end : int
            Sizes of mu and nu (m where the impulse is present, else 0).
        """
        def build():
            start, m_start = momentum_condition(system, "start_momentum", "mu", self.start_impulse)
            end, m_end = momentum_condition(system, "end_momentum", "nu", self.end_impulse)
            return start, end, m_start, m_end
        return _CONDITIONS.get((system.key, self), build)

    def omega_flat(self, z, z_plus):
        """Omega_d+^flat or Omega_d-^flat of (15)/(16): the Dirac structure's target."""
        raise NotImplementedError

    @property
    def free_component(self):
        """Index of the component of D+-L_d - Omega^flat allowed in Delta° (the fibre over
        the d'Alembert node): 2 (over q_k in T*(Q x Q*)) or 3 (over q_{k+1} in T*(Q* x Q))."""
        return 2 + self.multiplier_node

    def __repr__(self):
        return f"{type(self).__name__}()"


class PlusForm(Formulation):
    """The conventions of the (+) forms (37) and (39), Dirac structure D^{d+} (36)/(38).

    lam_k multiplies A(q_k) in the row of d/dq_k; p_0 is the momentum of the initial
    data, and the impulse at q_N is a boundary unknown of the optimizer:
    p_N = dL/dv(q_N, v_N) + A(q_N)^T nu.
    """

    name, label, multiplier_node, end_impulse, impulse_side = "+", "plus", 0, -1, -0.5

    def step_momentum(self, system, q0, p_carried, nu):
        return p_carried, nu

    def node_impulses(self, lam, mu, m):
        return lam[:, :m]

    def trajectory_blocks(self, p_carried, p_used, nu, m):
        return p_carried, nu, np.zeros(nu.shape[:-2] + (m,))

    def omega_flat(self, z, z_plus):
        return omega_flat_plus(z, z_plus)


class MinusForm(Formulation):
    """The conventions of the (-) forms (41) and (43), Dirac structure D^{d-} (40)/(42).

    lam_k multiplies A(q_{k+1}) in the row of d/dq_{k+1}, so the impulse at q_k is the
    previous step's multiplier; the start needs an impulse mu,
    p_0 = dL/dv(q_0, v_0) - A(q_0)^T mu, and lam_{N-1} is the impulse at q_N. A simulation
    applies mu at the start (`Trajectory.mu`) and ends with lam_{N-1} = 0.
    """

    name, label, multiplier_node, start_impulse, impulse_side = "-", "minus", 1, 1, 0.5
    end_momentum_determined = False

    def step_momentum(self, system, q0, p_carried, nu):
        at_q0, interior = ca.vertsplit(nu, [0, system.m, nu.numel()])
        impulse = ca.mtimes(system.constraint_matrix(q0).T, at_q0)
        return p_carried - impulse, ca.vertcat(ca.SX.zeros(system.m), interior)

    def node_impulses(self, lam, mu, m):
        return np.vstack([mu[None, :m], lam[:-1, :m]])

    def trajectory_blocks(self, p_carried, p_used, nu, m):
        N = nu.shape[-2]
        node = np.concatenate([nu[..., 1:, :m], np.zeros(nu.shape[:-2] + (min(N, 1), m))], axis=-2)
        return (np.concatenate([p_used, p_carried[..., -1:, :]], axis=-2),
                np.concatenate([node, nu[..., m:]], axis=-1), (nu[..., 0, :m] if N else None))

    def omega_flat(self, z, z_plus):
        return omega_flat_minus(z, z_plus)


def momentum_condition(system, label, multiplier, sign):
    """The momentum boundary row ``label(q, p, v, multiplier) -> r`` (shape (n,)) and the
    multiplier's size (m, or 0 when `sign` is 0): r = 0 says that p + sign A(q)^T
    multiplier is the momentum of v at q (`system.momentum_residual`: p - dL/dv(q, v) for a
    MechanicalSystem, dH/dp(q, p) - v for a HamiltonianSystem).

    The formulations (`dmoc.formulations`) say which end carries an impulse and with which
    sign: (+) p_N = dL/dv(q_N, v_N) + A(q_N)^T nu, (-) p_0 = dL/dv(q_0, v_0) - A(q_0)^T mu,
    A(q) holding every constraint one-form (the holonomic ones' dg/dq included).
    """
    n, size = system.n, system.m if sign else 0
    q, p, v, mult = ca.SX.sym("q", n), ca.SX.sym("p", n), ca.SX.sym("v", n), ca.SX.sym(multiplier, size)
    impulse = sign * ca.mtimes(system.constraint_matrix(q).T, mult) if sign else 0
    r = system.momentum_residual(q, p + impulse, v)
    return ca.Function(label, [q, p, v, mult], [r], ["q", "p", "v", multiplier], ["r"]), size
