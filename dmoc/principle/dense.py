"""Dense output of a discrete trajectory (the principle stage's solution between the knots):
q(t) and v(t) = q'(t) from the rule's own interpolant through q_k, the stage configurations
and q_{k+1} (the polynomial on which the action sum (46)/(47) evaluates L), p(t) from the
knot momenta, u(t) from the step's control values at the rule's control nodes. Used by
`Trajectory.sample` and `Trajectory.control`.
"""

from typing import NamedTuple

import numpy as np

from .._util import checks
from ..discrete.rules import lagrange_basis
from ..errors import InputError

# times this far (relative to the horizon t_N - t_0) past t_0 or t_N are round-off of the
# ends, e.g. t_0 + N h computed in another order; they are read as the end
END_RTOL = 1e-9


class Sample(NamedTuple):
    """The dense solution at K times (`Trajectory.sample`); for a scalar time t is a float
    and every array loses its first axis.

    Attributes
    ----------
    t : ndarray, shape (K,)
    q, v, p : ndarray, shape (K, n)
        Configuration, velocity q'(t) and momentum.
    u : ndarray, shape (K, n_u)
        Control.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    p: np.ndarray
    u: np.ndarray


def step_times(traj, t):
    """(t, k, c) for times `t` in the horizon of `traj`: the times as a 1-D array, the step
    k of each (a knot belongs to the step that starts there, the last knot to the last
    step) and the step time c = (t - t_k)/h in [0, 1] (0 and 1 exactly at the knots).

    Raises
    ------
    InputError
        If `traj` has no step, `t` is not a time or a 1-D array of times, or a time lies
        outside [t_0, t_N] by more than END_RTOL (t_N - t_0) or is not finite.
    InputTypeError
        If `t` is not made of real numbers.
    """
    if not traj.steps:
        raise InputError("this trajectory has 0 steps: there is no solution between knots to evaluate.")
    t = np.atleast_1d(checks.real_array("t", t, "a time or a 1-D array of times"))
    if t.ndim != 1:
        raise InputError(f"`t` must be a time or a 1-D array of times; got shape {t.shape}.")
    t0, tN = float(traj.t[0]), float(traj.t[-1])
    slack = END_RTOL * max(tN - t0, traj.h)
    outside = ~((t >= t0 - slack) & (t <= tN + slack))      # NaN counts as outside
    if outside.any():
        j = int(np.argmax(outside))
        raise InputError(f"`t` must lie in the horizon [t_0, t_N] = [{t0!r}, {tN!r}]; t[{j}] = "
                         f"{float(t[j])!r} is outside (the solution is not extrapolated).")
    t = np.clip(t, t0, tN)
    # the last knot at or before t (the stored t_k, exactly: floor((t_k - t_0)/h) can round
    # to k - 1)
    k = np.clip(np.searchsorted(traj.t, t, side="right") - 1, 0, traj.steps - 1)
    # c = 1 exactly at the last knot, (t_N - t_{N-1})/h can round below it
    return t, k, np.where(t == traj.t[k + 1], 1.0, (t - traj.t[k]) / traj.h)


def controls(traj, k, c):
    """u at step times c of steps k, shape (K, n_u): the Lagrange interpolant of the step's
    values at `control_nodes` (`dmoc.discrete.rules.Rule.control_at`)."""
    basis, _ = lagrange_basis(traj.control_nodes, c)
    nodes = len(traj.control_nodes)         # explicit sizes: K = 0 times is an empty sample
    values = traj.u[k].reshape(len(k), nodes, traj.u.shape[1] // nodes)
    return np.einsum("tj,tju->tu", basis, values)


def configurations(traj, k, c):
    """(q, v) at step times c of steps k, shapes (K, n): the polynomial through q_k, the
    stage configurations Q_j (at `stage_nodes`, the last blocks of s) and q_{k+1}, and its
    derivative divided by h."""
    n, nodes = traj.q.shape[1], (0.0, *traj.stage_nodes, 1.0)
    stages = traj.s[k, traj.s.shape[1] - len(traj.stage_nodes) * n:].reshape(
        len(k), len(traj.stage_nodes), n)
    values = np.concatenate([traj.q[k, None], stages, traj.q[k + 1, None]], axis=1)
    basis, slope = lagrange_basis(nodes, c)
    return (np.einsum("tj,tjn->tn", basis, values),
            np.einsum("tj,tjn->tn", slope, values) / traj.h)


def momenta(traj, k, c):
    """p at step times c of steps k, shape (K, n): on each step the polynomial of the
    configuration's degree d = len(stage_nodes) + 1 through the momenta of the d + 1 knots
    nearest the step (k - (d-1)//2 ... within [0, N]; fewer where N < d)."""
    d = min(len(traj.stage_nodes) + 1, traj.steps)
    first = np.clip(k - (d - 1) // 2, 0, traj.steps - d)
    basis, _ = lagrange_basis(np.arange(d + 1.0), k - first + c)
    stencil = traj.p[first[:, None] + np.arange(d + 1)]
    return np.einsum("tj,tjn->tn", basis, stencil)


def sample(traj, t):
    """The `Sample` of `traj` at times `t` (a scalar, or a 1-D array of K times)."""
    times, k, c = step_times(traj, t)
    q, v = configurations(traj, k, c)
    values = Sample(times, q, v, momenta(traj, k, c), controls(traj, k, c))
    return Sample(float(times[0]), *(x[0] for x in values[1:])) if np.ndim(t) == 0 else values
