"""A discrete curve on SO(3) x R^n_x (principle stage): the rotations R_k, the body
angular momenta Pi_k and the Cayley coordinates f_k of the increments F_k = R_k^T R_{k+1}
of a rigid body whose steps solve the group step residual (`group_residual`), with its
vector coordinates x_k, their momenta and the constraint multipliers, and the quantities
its tests and users read off it; its fields checked as ``Trajectory(...)`` checks its own
(`trajectory_fields`), sampled between the knots on the group (`group_dense`) and saved to
.npz files that round-trip exactly (`trajectory_file`)."""

from dataclasses import dataclass

import numpy as np

from .._util import checks
from ..errors import InputError
from . import group_dense, trajectory_fields
from .trajectory_file import ROTATION_TRAJECTORY_FILE, read, write


@dataclass
class RotationTrajectory:
    """Time-major arrays of a rigid body's motion on SO(3) (`dmoc.simulate` of a
    `GroupDiscretization`, the trajectory of `dmoc.optimize`'s result on the group).

    Every field is checked and copied, as ``Trajectory(...)`` does: shapes, real numbers
    (NaN allowed, the last iterate of a failed solve may hold it; never infinities), the
    knot times on the grid t_0 + k h. R is not checked to be orthogonal (a failed solve's
    iterate need not be).

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

    # the step's nodes as `Trajectory` names them (for `dense`): a control held on each
    # step, no stages
    control_nodes = (0.5,)
    stage_nodes = ()

    def __post_init__(self):
        R = checks.real_array("R", self.R, "an array of real numbers of shape (N+1, 3, 3)")
        if R.ndim != 3 or R.shape[0] < 1 or R.shape[1:] != (3, 3):
            raise InputError(f"`R` must have shape (N+1, 3, 3), one rotation per knot; got {R.shape}.")
        self.R = checks.array("R", R, R.shape, allow_nan=True)
        N1 = R.shape[0]
        self.h = checks.positive_float("h", self.h)
        self.t = trajectory_fields.time_grid(self.t, N1, self.h)
        self.Pi = checks.array("Pi", self.Pi, (N1, 3), allow_nan=True)
        self.f, self.u, self.lam = (trajectory_fields.per_step(name, value, N1 - 1) for name, value
                                    in (("f", self.f), ("u", self.u), ("lam", self.lam)))
        n_x = self.f.shape[1] - 3
        if n_x < 0:
            raise InputError(f"`f` must have 3 + n_x columns (the Cayley coordinates, then "
                             f"dx_k); got {self.f.shape[1]}.")
        empty = np.zeros((N1, 0))
        self.x, self.p_x = (checks.array(name, empty if value is None else value, (N1, n_x),
                                         allow_nan=True)
                            for name, value in (("x", self.x), ("p_x", self.p_x)))

    @classmethod
    def unchecked(cls, t, R, Pi, f, u, h, x, p_x, lam):
        """The RotationTrajectory of these fields as they are: no check, no copy.

        For dmoc's consumers (the simulator and the optimizer on the group), which build
        every field with the shapes and types the checks of ``RotationTrajectory(...)``
        would give it (float arrays, `h` a float): those checks and copies cost about half
        of a compiled 10^5-step simulation of the Chaplygin sphere. The arrays are kept as
        given, views included: nothing else may write to them.
        """
        traj = object.__new__(cls)
        traj.__dict__.update(t=t, R=R, Pi=Pi, f=f, u=u, h=h, x=x, p_x=p_x, lam=lam)
        return traj

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

    def __repr__(self):
        return (f"RotationTrajectory(steps={self.steps}, n_x={self.x.shape[1]}, "
                f"m={self.lam.shape[1]}, n_u={self.u.shape[1]}, h={self.h})")

    def sample(self, t):
        """The motion at any times of the horizon on an orthogonal interpolant
        (`group_dense.sample`): R(t) = R_k cay(c f_k), c = (t - t_k)/h, the step's own
        Cayley increment scaled along its axis, x(t) the chord, (Omega, x') its
        derivative, (Pi, p_x) linear between the knots, u held; the stored values at the
        knots.

        Parameters
        ----------
        t : float or array_like, shape (K,)
            Times in [t_0, t_N] (`Trajectory.control` says how the ends are read).

        Returns
        -------
        RotationSample
            t (K,), R (K, 3, 3), x (K, n_x), v = (Omega, x') and p = (Pi, p_x) (K, 3 + n_x),
            u (K, n_u); for a scalar `t`, t a float and the others without their first axis.

        Raises
        ------
        InputError
            If a time lies outside [t_0, t_N] or is not finite, or the trajectory has no step.
        InputTypeError
            If `t` is not made of real numbers.
        """
        return group_dense.sample(self, t)

    def save(self, path):
        """Write every field to an uncompressed .npz file at exactly `path` (exact round
        trip), atomically, as `Trajectory.save` does."""
        write(self, path)

    @classmethod
    def load(cls, path):
        """Read a RotationTrajectory written by `save` (or the trajectory of a result on the
        group written by `OptimizationResult.save`); never unpickles.

        Raises
        ------
        MissingFileError
            If there is no file at `path` (a FileNotFoundError).
        InputError
            If `path` is a folder.
        TrajectoryFileError
            If the file is empty, truncated, corrupted, not written by `save`, or the file of
            a `Trajectory` (of a vector space: read it with `Trajectory.load`).
        """
        return read(cls, path, ROTATION_TRAJECTORY_FILE)[0]
