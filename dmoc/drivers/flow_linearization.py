"""The linearization of the discrete flow map along a trajectory (a driver: feedback around
an optimum): the (+) step of (37) (or (39)) defines (q_{k+1}, p_{k+1}) from (q_k, p_k, u_k)
implicitly, with the multiplier lambda_k and the stages solved with them, and the implicit
function theorem on the step residual gives its Jacobians exactly for the discrete system:
the matrices the simulator's Newton iteration already factors, evaluated at the solved step.
"""

import casadi as ca
import numpy as np

from .._util import checks
from .._util.cache import BoundedCache
from ..discrete import Discretization
from ..errors import InputError
from ..principle.residual import step_residual
from ..principle.trajectory import Trajectory, check_trajectory

_JACOBIANS = BoundedCache(16, "flow_jacobians")     # the residual's Jacobians, by residual key


def flow_jacobians(disc, trajectory):
    """The Jacobians A_k, B_k of the discrete flow map (q_k, p_k, u_k) -> (q_{k+1}, p_{k+1})
    of the (+) step equations (37)/(39) at every step of `trajectory`.

    Parameters
    ----------
    disc : Discretization
        The model: system and rule (its h is not read: the trajectory's is).
    trajectory : Trajectory
        A solution of the (+) step equations of `disc` (an optimum, `optimize(...).trajectory`,
        or a simulation): its q, p, lam, s, u and h.

    Returns
    -------
    A : ndarray, shape (N, 2n, 2n)
        d(q_{k+1}, p_{k+1}) / d(q_k, p_k).
    B : ndarray, shape (N, 2n, len(control_nodes) * n_u)
        d(q_{k+1}, p_{k+1}) / du_k.

    Raises
    ------
    InputError
        A trajectory of the (-) form, whose step reads the impulse of the step before
        (the residual alone is not a map of (q_k, p_k)), or a step where the residual's
        Jacobian in its unknowns is singular (the step map is not locally unique there).

    Notes
    -----
    With z = (q_{k+1}, p_{k+1}, lambda_k, s_k) the unknowns of step k and x = (q_k, p_k),
    R(x, z, u_k, h) = 0 gives dz = -R_z^{-1} (R_x dx + R_u du), whose first 2n rows are A_k
    and B_k. The multiplier is eliminated with the step, so the linearization respects the
    constraint sets: every (dq_{k+1}, dp_{k+1}) it gives keeps the discrete constraint
    omega_d(q_k, q_{k+1}) = 0 (28) (and g(q_{k+1}) = 0) to first order, and a change of p_k
    along A(q_k)^T is taken up by lambda_k (the constraint impulse), so A_k maps the
    directions (0, A(q_k)^T mu) to zero. The coordinates are the simulator's (q, p) in
    R^{2n}; no reduction to a minimal set is made (the reachable directions are those of
    the constraint manifold, and a quadratic cost on the others is harmless: no control
    moves them).

    Examples
    --------
    >>> import dmoc
    >>> disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    >>> run = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0.5], steps=5, controls=[[0.1, 0.0]] * 5)
    >>> A, B = flow_jacobians(disc, run.trajectory)
    >>> A.shape, B.shape
    ((5, 6, 6), (5, 6, 2))
    """
    checks.instance("disc", disc, Discretization, "a Discretization")
    checks.instance("trajectory", trajectory, Trajectory, "a Trajectory")
    check_trajectory(disc, trajectory)
    residual = step_residual(disc, trajectory.variant)
    if residual.formulation.multiplier_node != 0:
        raise InputError(f"`trajectory` must be of the (+) form (variant '+'); got variant "
                         f"{trajectory.variant!r}, whose step reads the impulse of the step before. "
                         f"Solve or simulate the same problem with variant='+'.")
    jacobians = _JACOBIANS.get(residual.key, lambda: _residual_jacobians(residual))
    T, N, n = trajectory, trajectory.steps, disc.system.n
    columns = [T.q[:-1], T.p[:-1], T.q[1:], T.p[1:], T.lam, T.s, T.u, np.full((N, 1), T.h)]
    R_z, R_x, R_u = (_per_step(block, N) for block in jacobians.map(N)(*[c.T for c in columns]))
    condition = np.linalg.cond(R_z)
    if not (condition < _SINGULAR).all():
        k = int(np.argmax(~(condition < _SINGULAR)))
        raise InputError(f"the step equations of `trajectory` do not define a local step map at "
                         f"step {k} (t = {T.t[k]:.6g}): the residual's Jacobian in (q1, p1, lam, s) "
                         f"has condition number {condition[k]:.3g}.")
    dz = -np.linalg.solve(R_z, np.concatenate([R_x, R_u], axis=2))
    return dz[:, :2 * n, :2 * n], dz[:, :2 * n, 2 * n:]


_SINGULAR = 1e13        # a condition number beyond which the solve has lost every digit


def _per_step(block, N):
    """A mapped Jacobian, (rows, N * cols) step after step, as shape (N, rows, cols)."""
    array = np.array(block)
    return array.reshape(array.shape[0], N, -1).transpose(1, 0, 2)


def _residual_jacobians(residual):
    """The Function (q0, p0, q1, p1, lam, s, u, h) -> (R_z, R_x, R_u) of `residual`: its
    Jacobians in the unknowns z = (q1, p1, lam, s), in x = (q0, p0) and in u."""
    f = residual.function
    symbols = {name: ca.SX.sym(name, f.size1_in(name)) for name in f.name_in()}
    r = f(**symbols)["r"]
    z = ca.vertcat(*(symbols[k] for k in ("q1", "p1", "lam", "s")))
    x = ca.vertcat(symbols["q0"], symbols["p0"])
    blocks = [ca.densify(ca.jacobian(r, v)) for v in (z, x, symbols["u"])]
    names = list(f.name_in())
    return ca.Function("flow_jacobians", [symbols[k] for k in names], blocks, names, ["R_z", "R_x", "R_u"])
