"""Time-varying LQR feedback around a trajectory (a driver: feedback between or instead of
re-solves): the backward Riccati recursion of the discrete flow's exact linearization
(`dmoc.drivers.flow_linearization`) with the user's weights, and the gains that correct the
planned controls from a measured (q, p).
"""

import dataclasses

import numpy as np

from .._util import checks
from ..errors import InputError
from .flow_linearization import flow_jacobians


@dataclasses.dataclass(frozen=True)
class FeedbackGains:
    """Time-varying LQR gains along a trajectory (`tvlqr`).

    Attributes
    ----------
    trajectory : Trajectory
        The trajectory (q*, p*, u*) the gains are taken around.
    A, B : ndarray, shapes (N, 2n, 2n) and (N, 2n, n_c)
        The flow's Jacobians (`flow_jacobians`), n_c = len(control_nodes) * n_u.
    K : ndarray, shape (N, n_c, 2n)
        The gains: u_k = u*_k - K_k (x_k - x*_k), x = (q, p).
    P : ndarray, shape (N+1, 2n, 2n)
        The cost-to-go matrices of the recursion, P_N = Q_N.
    """

    trajectory: object
    A: np.ndarray
    B: np.ndarray
    K: np.ndarray
    P: np.ndarray

    def control(self, k, q, p):
        """The controls of step `k` from the measured (q_k, p_k): u*_k - K_k (x_k - x*_k),
        shape (n_c,).

        Parameters
        ----------
        k : int
            0 <= k < N.
        q, p : array_like, shape (n,)
            The measured configuration and momentum (the simulator's p_k; a plant's
            dL/dv(q, v) may differ from it along A(q)^T, which the gains do not read).
        """
        T = self.trajectory
        if not isinstance(k, (int, np.integer)) or isinstance(k, bool) or not 0 <= k < T.steps:
            raise InputError(f"`k` must be a step of the trajectory, an int 0 <= k < {T.steps}; got {k!r}.")
        n = T.q.shape[1]
        x = np.concatenate([checks.array("q", q, (n,)), checks.array("p", p, (n,))])
        return T.u[k] - self.K[k] @ (x - np.concatenate([T.q[k], T.p[k]]))


def tvlqr(disc, trajectory, Q, R, *, Q_N=None):
    """Time-varying LQR gains around `trajectory` from the exact linearization of the
    discrete (+) step (37)/(39).

    Parameters
    ----------
    disc : Discretization
        The model (`flow_jacobians`).
    trajectory : Trajectory
        The trajectory to track, of the (+) form, e.g. an optimum's.
    Q : array_like, shape (2n, 2n)
        Weight of the deviation x - x* = (q - q*, p - p*) at the knots 0 ... N-1;
        symmetric positive semidefinite.
    R : array_like, shape (n_c, n_c)
        Weight of the control deviation of one step (its controls at the rule's control
        nodes, n_c = len(control_nodes) * n_u); symmetric positive definite.
    Q_N : array_like, shape (2n, 2n), optional
        Weight at the last knot (default `Q`).

    Returns
    -------
    FeedbackGains

    Notes
    -----
    Minimizing sum_k (x_k^T Q x_k + u_k^T R u_k) + x_N^T Q_N x_N subject to x_{k+1} = A_k
    x_k + B_k u_k (deviations from the trajectory) by the backward recursion P_N = Q_N,
    K_k = (R + B_k^T P_{k+1} B_k)^{-1} B_k^T P_{k+1} A_k, P_k = Q + A_k^T P_{k+1} (A_k - B_k K_k).
    A_k is singular on the directions of p along A(q_k)^T (`flow_jacobians`): the gains
    read no such direction of the measured momentum.

    Examples
    --------
    >>> import numpy as np, dmoc
    >>> disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    >>> run = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0.5], steps=5, controls=[[0.1, 0.0]] * 5)
    >>> gains = tvlqr(disc, run.trajectory, np.eye(6), np.eye(2))
    >>> gains.K.shape, gains.control(0, [0, 0.01, 0], [1, 0, 0.5]).shape
    ((5, 2, 6), (2,))
    """
    A, B = flow_jacobians(disc, trajectory)
    size, n_c = A.shape[1], B.shape[2]
    Q = _weight("Q", Q, size)
    Q_N = Q if Q_N is None else _weight("Q_N", Q_N, size)
    R = _weight("R", R, n_c, definite=True)
    N = A.shape[0]
    P, K = np.empty((N + 1, size, size)), np.empty((N, n_c, size))
    P[N] = Q_N
    for k in range(N - 1, -1, -1):
        PA, PB = P[k + 1] @ A[k], P[k + 1] @ B[k]
        K[k] = np.linalg.solve(R + B[k].T @ PB, PB.T @ A[k])
        P[k] = Q + A[k].T @ (PA - PB @ K[k])
        P[k] = (P[k] + P[k].T) / 2
    return FeedbackGains(trajectory, A, B, K, P)


def _weight(name, value, size, definite=False):
    """`value` as a symmetric (size, size) matrix, positive semidefinite (or definite)."""
    W = checks.array(name, value, (size, size))
    if not np.allclose(W, W.T, rtol=1e-12, atol=0):
        raise InputError(f"`{name}` must be symmetric; got an asymmetry of {np.abs(W - W.T).max():.3g}.")
    lowest = np.linalg.eigvalsh(W).min()
    if lowest < -1e-12 * max(1.0, np.abs(W).max()) or (definite and lowest <= 0):
        kind = "positive definite" if definite else "positive semidefinite"
        raise InputError(f"`{name}` must be {kind}; its smallest eigenvalue is {lowest:.3g}.")
    return W
