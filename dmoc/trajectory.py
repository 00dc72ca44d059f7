"""Trajectory: the discrete solution both consumers return, time-major arrays with save/load
to .npz that round-trips exactly.
"""

from dataclasses import dataclass, field, fields

import numpy as np

from . import _checks
from .formulations import FORMULATIONS


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

    def __post_init__(self):
        # NaN is allowed in the arrays: the last iterate of a failed solve may hold it, and
        # is kept rather than lost. Every array is copied, never a view of solver memory.
        q = np.array(self.q, dtype=float)
        if q.ndim != 2 or q.shape[0] < 1:
            raise ValueError(f"`q` must have shape (N+1, n); got {q.shape}.")
        self.q = _checks.array("q", q, q.shape, allow_nan=True)
        N1, n = q.shape
        self.t = _checks.array("t", self.t, (N1,), allow_nan=True)
        self.p = _checks.array("p", self.p, (N1, n), allow_nan=True)
        self.lam, self.u, self.s = (_per_step(name, value, N1 - 1) for name, value in
                                    (("lam", self.lam), ("u", self.u), ("s", self.s)))
        self.h = _checks.positive_float("h", self.h)
        self.variant = _checks.choice("variant", self.variant, tuple(FORMULATIONS))
        self.control_nodes = tuple(float(c) for c in np.ravel(self.control_nodes))
        if not self.control_nodes or self.u.shape[1] % len(self.control_nodes):
            raise ValueError(f"`u` must have a multiple of len(control_nodes) = "
                             f"{len(self.control_nodes)} columns; got {self.u.shape[1]}.")
        self.mu = (np.zeros(self.lam.shape[1]) if self.mu is None else
                   _checks.array("mu", self.mu, (np.size(self.mu),), allow_nan=True))

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
        """The control u(t), shape (len(t), n_u): on each step the Lagrange interpolant of
        its values at `control_nodes` (a held control for ``(0.5,)``); a time on a knot
        belongs to the step that starts there (the last knot to the last step).

        >>> traj = Trajectory([0, 1, 2], [[0.0]] * 3, [[0.0]] * 3, [[], []], [[0.0, 2.0], [2.0, 4.0]],
        ...                   1.0, "+", control_nodes=(0.0, 1.0))
        >>> traj.control([0.25, 1.5, 2.0])[:, 0]
        array([0.5, 3. , 4. ])
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        nodes = np.asarray(self.control_nodes)
        k = np.clip(np.floor((t - self.t[0]) / self.h).astype(int), 0, max(self.steps - 1, 0))
        tau = (t - self.t[k]) / self.h
        values = self.u[k].reshape(len(t), len(nodes), -1)
        basis = np.ones((len(t), len(nodes)))
        for j, c in enumerate(nodes):
            for i, other in enumerate(nodes):
                if i != j:
                    basis[:, j] *= (tau - other) / (c - other)
        return np.einsum("tj,tju->tu", basis, values)

    def save(self, path):
        """Write every field to an uncompressed .npz file at exactly `path` (exact round trip)."""
        with open(path, "wb") as file:
            np.savez(file, **{f.name: np.asarray(getattr(self, f.name)) for f in fields(self)})

    @classmethod
    def load(cls, path):
        """Read a Trajectory written by `save`."""
        with np.load(path, allow_pickle=False) as data:
            values = {f.name: data[f.name] for f in fields(cls) if f.name in data.files}
        values["h"] = float(values["h"])
        values["variant"] = str(values["variant"])
        return cls(**values)

    def __repr__(self):
        return (f"Trajectory(steps={self.steps}, n={self.q.shape[1]}, m={self.lam.shape[1]}, "
                f"n_u={self.u.shape[1]}, h={self.h}, variant={self.variant!r})")


def _per_step(name, value, N):
    """A per-step array of shape (N, k); empty input (or None) means k = 0."""
    data = np.array(np.zeros((N, 0)) if value is None else value, dtype=float)
    if data.size == 0:
        data = data.reshape(N, 0) if N else np.zeros((0, data.shape[-1] if data.ndim == 2 else 0))
    if data.ndim != 2 or data.shape[0] != N:
        raise ValueError(f"`{name}` must have shape ({N}, k), one row per step; got {data.shape}.")
    return _checks.array(name, data, data.shape, allow_nan=True)
