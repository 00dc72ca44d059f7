"""Trajectory: the discrete solution both consumers return, time-major arrays whose fields
are checked (`trajectory_fields`), sampled between the knots (`dense`) and saved to .npz
files that round-trip exactly (`trajectory_file`); and the checks of a trajectory against a
discretization, its sizes and its discrete constraint omega_d (28) per step.
"""

from dataclasses import dataclass, field

import numpy as np

from .._util import checks
from .._util.numeric import per_step
from ..errors import InputError
from ..discrete import Discretization
from . import dense, trajectory_fields
from .formulations import FORMULATIONS
from .trajectory_file import TRAJECTORY_FILE, read, write


@dataclass(eq=False)
class Trajectory:
    """A discrete trajectory of the (+) or (-) implicit discrete Lagrangian system (37)/(41).

    Attributes
    ----------
    t : ndarray, shape (N+1,)
        Knot times t_k = t_0 + k h.
    q : ndarray, shape (N+1, n)
        Configurations q_k.
    p : ndarray, shape (N+1, n)
        Momenta p_k.
    lam : ndarray, shape (N, m)
        Constraint multipliers of each step: at q_k for variant "+", at q_{k+1} for "-".
    u : ndarray, shape (N, len(control_nodes) * n_u)
        Controls of each step at its control nodes, node by node: u(t_k + c_j h) = u[k,
        j n_u:(j+1) n_u]; between them u(t) is their Lagrange interpolant on the step
        (`control`). With ``control_nodes = (0.5,)`` a control held on [t_k, t_{k+1}].
    h : float
        Step size.
    variant : {"+", "-"}
        Name of the formulation (`dmoc.formulations`) whose equations the steps solve.
    mu : ndarray, shape (m,)
        Initial impulse of a (-) run: p_0 = p_start - A(q_0)^T mu (zeros for "+"; default
        zeros of lam's width).
    s : ndarray, shape (N, n_stages)
        Stage unknowns of each step (empty columns for stage-free rules).
    control_nodes : tuple of float
        Step times c in [0, 1] of the controls in `u` (the rule's ``control_nodes``);
        default ``(0.5,)``, one control held over each step.
    stage_nodes : tuple of float
        Step times c in (0, 1) of the configurations among the stages, the last
        ``len(stage_nodes) * n`` columns of `s` (the rule's ``stage_nodes``): with q_k and
        q_{k+1} the nodes of the rule's interpolant q(t) on each step (`sample`); default
        ``()``, the chord.
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    lam: np.ndarray
    u: np.ndarray
    h: float
    variant: str
    mu: np.ndarray = field(default=None)
    s: np.ndarray = field(default=None)
    control_nodes: tuple = (0.5,)
    stage_nodes: tuple = ()

    def __post_init__(self):
        # NaN is allowed in q, p, lam, u, s, mu: the last iterate of a failed solve may hold
        # it, and is kept rather than lost. Every array is copied, never a view of solver
        # memory. Complex numbers, strings and ragged rows are refused (`checks.real_array`).
        q = checks.real_array("q", self.q, "an array of real numbers of shape (N+1, n)")
        if q.ndim != 2 or q.shape[0] < 1:
            raise InputError(f"`q` must have shape (N+1, n); got {q.shape}.")
        self.q = checks.array("q", q, q.shape, allow_nan=True)
        N1, n = q.shape
        self.h = checks.positive_float("h", self.h)
        self.t = trajectory_fields.time_grid(self.t, N1, self.h)
        self.p = checks.array("p", self.p, (N1, n), allow_nan=True)
        self.lam, self.u, self.s = (trajectory_fields.per_step(name, value, N1 - 1) for name, value
                                    in (("lam", self.lam), ("u", self.u), ("s", self.s)))
        self.variant = checks.choice("variant", self.variant, tuple(FORMULATIONS))
        self.control_nodes = trajectory_fields.control_nodes(self.control_nodes, self.u.shape[1])
        self.stage_nodes = trajectory_fields.stage_nodes(self.stage_nodes, n, self.s.shape[1])
        self.mu = (np.zeros(self.lam.shape[1]) if self.mu is None else
                   checks.array("mu", self.mu, (np.size(self.mu),), allow_nan=True))

    @classmethod
    def unchecked(cls, t, q, p, lam, u, h, variant, mu, s, control_nodes, stage_nodes):
        """The Trajectory of these fields as they are: no check, no copy.

        For dmoc's consumers, which build every field with the shapes and types the
        checks of ``Trajectory(...)`` would give it (float arrays, `h` a float, `variant`
        a formulation's name, the nodes tuples of floats): those checks cost as much
        as a short simulation's steps. The arrays are kept as given,
        views included: nothing else may write to them. Construct a Trajectory of your
        own arrays with ``Trajectory(...)``, which checks and copies them.
        """
        traj = object.__new__(cls)
        traj.__dict__.update(t=t, q=q, p=p, lam=lam, u=u, h=h, variant=variant, mu=mu, s=s,
                             control_nodes=control_nodes, stage_nodes=stage_nodes)
        return traj

    @classmethod
    def assembled(cls, t, q, p, lam, u, h, variant, mu, s, control_nodes, stage_nodes,
                  final=False):
        """The Trajectory of these fields made as ``Trajectory(...)`` makes them (each array
        a float array of its own, `mu` None as zeros, `h` a float, the nodes tuples of
        floats), without its checks (`unchecked`); with `final`, of its last knot only:
        t, q, p of shape (1, ...) at t_N, lam, u, s with no row, h, mu and the nodes
        kept (only those rows are copied).

        For dmoc's consumers, whose fields meet those checks by construction (finite
        arrays of the right shapes, h > 0, a formulation's name, a rule's nodes): the
        simulator's runs and the optimizer's optima.
        """
        t, q, p, lam, u, h, mu, s = trajectory_fields.assembled(t, q, p, lam, u, h, mu, s, final)
        nodes = trajectory_fields.node_tuples(control_nodes, stage_nodes)
        return cls.unchecked(t, q, p, lam, u, h, variant, mu, s, *nodes)

    @classmethod
    def assembled_runs(cls, t, q, p, lam, u, h, variant, mu, s, control_nodes, stage_nodes,
                       final=False, memory=np.empty):
        """`assembled` of R runs of the same shapes at once: the arrays t (R, N+1), q, p
        (R, N+1, n), lam, u, s (R, N, ...), mu (R, m) or None, the other fields shared. A
        list of R Trajectories, the same fields as `assembled` of each run, whose arrays
        are its rows of one buffer, ``memory(size)``, a float array of shape (size,) (a new
        array by default; C-contiguous views: a trajectory kept alone keeps the arrays of
        all R alive)."""
        t, q, p, lam, u, h, mu, s = trajectory_fields.assembled(t, q, p, lam, u, h, mu, s, final,
                                                                memory)
        nodes = trajectory_fields.node_tuples(control_nodes, stage_nodes)
        return [cls.unchecked(t[i], q[i], p[i], lam[i], u[i], h, variant, mu[i], s[i], *nodes)
                for i in range(q.shape[0])]

    @property
    def steps(self):
        """Number of steps N."""
        return self.q.shape[0] - 1

    @property
    def velocities(self):
        """Step velocities (q_{k+1} - q_k)/h, shape (N, n): the velocity of each step at
        its midpoint, the one the midpoint rule and the retraction (28) use.

        >>> Trajectory([0, 1], [[0.0], [2.0]], [[0.0], [0.0]], [], [], 1.0, "+").velocities
        array([[2.]])
        """
        return np.diff(self.q, axis=0) / self.h

    def control(self, t):
        """The control u(t): on each step the Lagrange interpolant of its values at
        `control_nodes` (a held control for ``(0.5,)``); a time on a knot belongs to the
        step that starts there (the last knot to the last step).

        Parameters
        ----------
        t : float or array_like, shape (K,)
            Times in [t_0, t_N] (a round-off of ``dense.END_RTOL (t_N - t_0)`` past either
            end is read as the end): outside the horizon there is no control, and the
            step's polynomial would extrapolate.

        Returns
        -------
        ndarray, shape (K, n_u), or (n_u,) for a scalar `t`

        Raises
        ------
        InputError
            If a time lies outside [t_0, t_N] or is not finite.
        InputTypeError
            If `t` is not made of real numbers.

        >>> traj = Trajectory([0, 1, 2], [[0.0]] * 3, [[0.0]] * 3, [[], []], [[0.0, 2.0], [2.0, 4.0]],
        ...                   1.0, "+", control_nodes=(0.0, 1.0))
        >>> traj.control([0.25, 1.5, 2.0])[:, 0], traj.control(0.25)
        (array([0.5, 3. , 4. ]), array([0.5]))
        """
        times, k, c = dense.step_times(self, t)
        u = dense.controls(self, k, c)
        return u[0] if np.ndim(t) == 0 else u

    def sample(self, t):
        """The solution at any times of the horizon: q, v, p and u (`dense.Sample`).

        q(t) is the rule's interpolant on the step (`stage_nodes`): the polynomial of
        degree d = len(stage_nodes) + 1 through q_k, the stage configurations and q_{k+1},
        on which the discrete Lagrangian evaluates L (the chord for midpoint and trapezoid);
        v(t) = q'(t); p(t) the polynomial of the same degree through the momenta of the
        d + 1 knots nearest the step; u(t) as `control`. At the knots q, p and u are the
        stored values. Measured orders between the knots, for smooth solutions
        (tests/principle/test_sample.py, against DOP853): q and p d + 1, v d (midpoint and
        trapezoid 2, 2, 1; lobatto3 3, 3, 2; lobatto4 4, 4, 3); v jumps at the knots. With
        constraints the discrete p_k differ from dL/dv by an O(h) impulse along A(q_k)^T, so
        p converges on ker A(q) only, and on the first d steps (whose stencils hold the
        given p_0, without that impulse) as O(h^2).

        Parameters
        ----------
        t : float or array_like, shape (K,)
            Times in [t_0, t_N], as for `control`.

        Returns
        -------
        Sample
            Named arrays t (K,), q, v, p (K, n) and u (K, n_u); for a scalar `t`, t a
            float and the others without their first axis (q of shape (n,), ...).

        Raises
        ------
        InputError, InputTypeError
            As `control`.

        >>> traj = Trajectory([0, 1], [[0.0], [2.0]], [[1.0], [3.0]], [[]], [[5.0]], 1.0, "+")
        >>> traj.sample(0.25)
        Sample(t=0.25, q=array([0.5]), v=array([2.]), p=array([1.5]), u=array([5.]))
        """
        return dense.sample(self, t)

    def save(self, path):
        """Write every field to an uncompressed .npz file at exactly `path` (exact round
        trip). The write is atomic: a temporary file renamed over `path`, so a failure
        half-way leaves a previous file at `path` intact."""
        write(self, path)

    @classmethod
    def load(cls, path):
        """Read a Trajectory written by `save`; never unpickles.

        Raises
        ------
        MissingFileError
            If there is no file at `path` (a FileNotFoundError).
        InputError
            If `path` is a folder.
        TrajectoryFileError
            If the file is empty, truncated, corrupted or not written by `save`.
        """
        return read(cls, path, TRAJECTORY_FILE)[0]

    def __repr__(self):
        return (f"Trajectory(steps={self.steps}, n={self.q.shape[1]}, m={self.lam.shape[1]}, "
                f"n_u={self.u.shape[1]}, h={self.h}, variant={self.variant!r})")


def check_trajectory(disc, traj):
    """Raise unless `traj` fits `disc` (sizes of q, lam, u, s); return its number of steps."""
    checks.instance("disc", disc, Discretization, "a Discretization")
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    sizes = {"q": disc.system.n, "lam": disc.n_multipliers, "u": disc.n_controls, "s": disc.n_stages}
    for name, size in sizes.items():
        if getattr(traj, name).shape[1] != size:
            raise InputError(f"`traj.{name}` has {getattr(traj, name).shape[1]} columns; "
                             f"this discretization has {size}.")
    return traj.steps


def constraint_violation(disc, traj):
    """max_a |omega_d^a| of (28) (or of the stage rule's moment rows) for each step, shape (N,)."""
    if not check_trajectory(disc, traj) or disc.system.m == 0:
        return np.zeros(traj.steps)
    (omega,) = per_step(disc.discrete_constraint, traj.steps, traj.q[:-1], traj.q[1:],
                        traj.s, traj.h)
    return np.abs(omega).max(axis=1)
