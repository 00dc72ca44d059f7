"""A discrete curve on the rotation group (principle stage): the rotations R_k, the body
angular momenta Pi_k and the Cayley coordinates f_k of the increments F_k = R_k^T R_{k+1}
of a rigid body whose steps solve the group step residual (`group_residual`), with the
quantities its tests and users read off it."""

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
        The rotations R_k (body to space), R_{k+1} = R_k cay(f_k).
    Pi : numpy.ndarray, shape (N+1, 3)
        The body angular momenta Pi_k (the discrete momenta of the residual's rows).
    f : numpy.ndarray, shape (N, 3)
        The Cayley coordinates of each step's increment F_k = cay(f_k).
    u : numpy.ndarray, shape (N, n_u)
        The controls, held on each step.
    h : float
    """

    t: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    f: np.ndarray
    u: np.ndarray
    h: float

    @property
    def steps(self):
        """N, the number of steps."""
        return self.f.shape[0]

    @property
    def q(self):
        """The rows of each R_k one after another, shape (N+1, 9)."""
        return self.R.reshape(-1, 9)

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
