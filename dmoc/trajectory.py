"""Trajectory: the discrete solution both consumers return, time-major arrays with save/load
to .npz that round-trips exactly.
"""

from dataclasses import dataclass, field, fields

import numpy as np

from . import _checks


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
    u : ndarray, shape (N, n_u)
        Controls, constant on [t_k, t_{k+1}].
    h : float
        Step size.
    variant : {"+", "-"}
    mu : ndarray, shape (m,)
        Initial impulse of a (-) run: p_0 = p_start - A(q_0)^T mu (zeros for "+").
    s : ndarray, shape (N, n_stages)
        Stage unknowns of each step (empty columns for stage-free rules).
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

    def __post_init__(self):
        self.q = np.asarray(self.q, dtype=float)
        if self.q.ndim != 2:
            raise ValueError(f"`q` must have shape (N+1, n); got {self.q.shape}.")
        N1, n = self.q.shape
        N = N1 - 1
        self.t = _checks.array("t", self.t, (N1,), allow_nan=True)
        self.p = _checks.array("p", self.p, (N1, n), allow_nan=True)
        self.lam = np.asarray(self.lam, dtype=float)
        m = self.lam.shape[1] if self.lam.ndim == 2 else 0
        self.lam = _checks.array("lam", self.lam.reshape(N, m), (N, m), allow_nan=True)
        self.u = np.asarray(self.u, dtype=float)
        n_u = self.u.shape[1] if self.u.ndim == 2 else 0
        self.u = _checks.array("u", self.u.reshape(N, n_u), (N, n_u), allow_nan=True)
        self.h = float(self.h)
        self.variant = _checks.choice("variant", self.variant, ("+", "-"))
        self.mu = np.zeros(m) if self.mu is None else _checks.array("mu", self.mu, (m,), allow_nan=True)
        self.s = np.asarray(np.zeros((N, 0)) if self.s is None else self.s, dtype=float)
        n_s = self.s.shape[1] if self.s.ndim == 2 else 0
        self.s = _checks.array("s", self.s.reshape(N, n_s), (N, n_s), allow_nan=True)

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

    def save(self, path):
        """Write every field to an uncompressed .npz file at exactly `path` (exact round trip)."""
        with open(path, "wb") as file:
            np.savez(file, **{f.name: np.asarray(getattr(self, f.name)) for f in fields(self)})

    @classmethod
    def load(cls, path):
        """Read a Trajectory written by `save`."""
        with np.load(path, allow_pickle=False) as data:
            values = {f.name: data[f.name] for f in fields(cls)}
        values["h"] = float(values["h"])
        values["variant"] = str(values["variant"])
        return cls(**values)

    def __repr__(self):
        return (f"Trajectory(steps={self.steps}, n={self.q.shape[1]}, m={self.lam.shape[1]}, "
                f"n_u={self.u.shape[1]}, h={self.h}, variant={self.variant!r})")
