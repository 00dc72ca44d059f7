"""A discrete curve on SO(3) x R^n_x (principle stage): the rotations R_k, the body
angular momenta Pi_k and the Cayley coordinates f_k of the increments F_k = R_k^T R_{k+1}
of a rigid body whose steps solve the group step residual (`group_residual`), with its
vector coordinates x_k, their momenta and the constraint multipliers, and the quantities
its tests and users read off it."""

from dataclasses import dataclass

import numpy as np


@dataclass
class RotationTrajectory:
    """Time-major arrays of a rigid body's motion on SO(3) (`dmoc.simulate` of a
    `GroupDiscretization`).

    Attributes
    ----------
    t : numpy.ndarray, shape (N+1,)
    R : numpy.ndarray, shape (N+1, 3, 3)
        The rotations R_k (body to space), R_{k+1} = R_k cay(f_k[:3]).
    Pi : numpy.ndarray, shape (N+1, 3)
        The body angular momenta Pi_k (the discrete momenta of the residual's rows).
    f : numpy.ndarray, shape (N, 3 + n_x)
        Each step's increment: the Cayley coordinates of F_k = cay(f_k[:3]), then
        dx_k = x_{k+1} - x_k.
    u : numpy.ndarray, shape (N, n_u)
        The controls, held on each step.
    h : float
    x : numpy.ndarray, shape (N+1, n_x)
        The vector coordinates x_k (none without them).
    p_x : numpy.ndarray, shape (N+1, n_x)
        Their momenta.
    lam : numpy.ndarray, shape (N, m)
        The multipliers of the constraint one-forms at q_k, the (+) form (37).
    """

    t: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    f: np.ndarray
    u: np.ndarray
    h: float
    x: np.ndarray = None
    p_x: np.ndarray = None
    lam: np.ndarray = None

    def __post_init__(self):
        k = self.R.shape[0]
        empty = np.zeros((k, 0))
        self.x = empty if self.x is None else self.x
        self.p_x = empty if self.p_x is None else self.p_x
        self.lam = np.zeros((k - 1, 0)) if self.lam is None else self.lam

    @property
    def steps(self):
        """N, the number of steps."""
        return self.f.shape[0]

    @property
    def q(self):
        """The configurations (the rows of R_k one after another, x_k), shape (N+1, 9 + n_x)."""
        return np.hstack([self.R.reshape(-1, 9), self.x])

    @property
    def p(self):
        """The momenta (Pi_k, p_x,k), shape (N+1, 3 + n_x)."""
        return np.hstack([self.Pi, self.p_x])

    @property
    def spatial_momentum(self):
        """The spatial angular momentum R_k Pi_k, shape (N+1, 3): conserved by the free body,
        its e3 component by the heavy top."""
        return np.einsum("kij,kj->ki", self.R, self.Pi)

    @property
    def orthogonality_defect(self):
        """max |R_k^T R_k - I| of each rotation, shape (N+1,)."""
        gram = np.einsum("kji,kjl->kil", self.R, self.R)
        return np.abs(gram - np.eye(3)).max(axis=(1, 2))
