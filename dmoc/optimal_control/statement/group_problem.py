"""Consumer 2 of the group step residual, its statement: a DMOC problem for a rigid body on
SO(3) (Kobilarov & Marsden, "Discrete geometric optimal control on Lie groups", IEEE T-RO
27 (2011)): minimize the discrete control effort sum_k h |u_k|^2 subject to the
`GroupStepResidual` at every step, from a rotation and body angular velocity to others.
Its NLP is `dmoc.optimal_control.nlp.group_transcription`.
"""

import numpy as np

from ..._util import checks
from ...discrete.group_discretization import GroupDiscretization
from ...errors import InputError
from ...mechanics.rotations import as_rotation
from ...principle.group_residual import group_step_residual


class GroupOptimalControlProblem:
    """A rigid body steered on SO(3): minimize sum_k h |u_k|^2 (the integral of |tau|^2 for
    controls held on each step) subject to the group step residual at every step.

    Parameters
    ----------
    disc : GroupDiscretization
        Of a RigidBody with controls (e.g. `dmoc.systems.spacecraft`); its h fixes the
        duration steps * h.
    steps : int
        N.
    R_start, R_goal : array_like, shape (3, 3)
        The rotations at t = 0 and t = N h.
    omega_start, omega_goal : array_like, shape (3,), optional
        Body angular velocities at the ends (default: at rest), so that Pi_0 = J
        omega_start and Pi_N = J omega_goal.

    Attributes
    ----------
    disc, steps, residual : GroupDiscretization, int, GroupStepResidual
    R_start, R_goal : numpy.ndarray, shape (3, 3)
    Pi_start, Pi_goal : numpy.ndarray, shape (3,)
        The body angular momenta the ends impose.

    Notes
    -----
    The NLP carries, per knot, the 9 entries of R_k and Pi_k, and per step the Cayley
    coordinates f_k and the control u_k; its rows per step are the 6 rows of the residual
    and the 9 rows R_{k+1} - R_k cay(f_k) (the residual's `reconstruction`), so every R_k
    is an exact group product of the start and the increments to the solver's tolerance.
    R_0 and the end momenta are fixed by bounds; the goal rotation is the 3 rows
    cay^{-1}(R_goal^T R_N) = 0 (the 9 entries of R_N = R_goal would be 6 rows too many).
    """

    def __init__(self, disc, steps, *, R_start, R_goal, omega_start=(0.0, 0.0, 0.0),
                 omega_goal=(0.0, 0.0, 0.0)):
        checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
        if disc.n_controls == 0:
            raise InputError("`disc` must be of a RigidBody with controls (n_u > 0), e.g. "
                             "dmoc.systems.spacecraft(); this one has none.")
        self.disc, self.steps = disc, checks.positive_int("steps", steps)
        self.residual = group_step_residual(disc)
        self.R_start, self.R_goal = as_rotation("R_start", R_start), as_rotation("R_goal", R_goal)
        J = disc.system.inertia
        self.Pi_start = J @ checks.array("omega_start", omega_start, (3,))
        self.Pi_goal = J @ checks.array("omega_goal", omega_goal, (3,))

    @property
    def duration(self):
        """N h."""
        return self.steps * self.disc.h

    def geodesic(self):
        """The rotations R_start exp(s log(R_start^T R_goal)), s = k/N, along the shortest
        rotation between the ends, shape (N+1, 3, 3): the default guess."""
        phi = rotation_vector(self.R_start.T @ self.R_goal)
        return np.array([self.R_start @ rotation_matrix(s * phi)
                         for s in np.linspace(0.0, 1.0, self.steps + 1)])

    def __repr__(self):
        return f"GroupOptimalControlProblem({self.disc!r}, steps={self.steps})"


def rotation_matrix(phi):
    """exp(phi^) by Rodrigues' formula, shape (3,) -> (3, 3)."""
    angle = np.linalg.norm(phi)
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if angle < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + np.sin(angle) / angle * K + (1 - np.cos(angle)) / angle ** 2 * K @ K


def rotation_vector(R):
    """log(R) as a vector (3,), the rotation angle in [0, pi) times the axis."""
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return 0.5 * axis if angle < 1e-12 else angle / (2 * np.sin(angle)) * axis
