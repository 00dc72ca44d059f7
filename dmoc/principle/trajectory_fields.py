"""The fields of a Trajectory (the principle stage's discrete solution) as it keeps them:
checked and copied from any values by ``Trajectory(...)`` (the knot times on the grid of h
within TIME_GRID_RTOL, the per-step arrays, the rule's control and stage nodes), or copied
without checks from the arrays of dmoc's consumers, which meet the checks by construction
(`Trajectory.assembled`, `Trajectory.assembled_runs`).
"""

import numpy as np

from .._util import checks
from ..errors import InputError

# max |t_k - t_0 - k h| allowed, relative to |t_0| + N h: rounding of t_0 + k h, of
# np.linspace and of cumulative sums of h stay far below it; a grid of another h does not.
TIME_GRID_RTOL = 1e-10


def time_grid(t, N1, h):
    """The knot times, shape (N+1,): finite and equal to t_0 + k h within TIME_GRID_RTOL."""
    t = checks.array("t", t, (N1,))
    k = np.arange(N1)
    off = np.abs(t - (t[0] + k * h))
    if off.max() > TIME_GRID_RTOL * (abs(t[0]) + (N1 - 1) * h):
        j = int(np.argmax(off))
        raise InputError(f"`t` must be the grid t_0 + k h with h = {h!r}; t[{j}] = {float(t[j])!r} "
                         f"is {off[j]:.3g} off (a grid of another step, or `h` not "
                         f"(t[-1] - t[0])/N?).")
    return t


def control_nodes(nodes, columns):
    """`nodes` as a tuple of distinct step times in [0, 1] that divides the u columns."""
    nodes = checks.real_array("control_nodes", nodes, "a sequence of step times in [0, 1]")
    nodes = tuple(float(c) for c in np.ravel(nodes))
    if not nodes or not all(0.0 <= c <= 1.0 for c in nodes) or len(set(nodes)) < len(nodes):
        raise InputError(f"`control_nodes` must be distinct step times in [0, 1]; got {nodes}.")
    if columns % len(nodes):
        raise InputError(f"`u` must have a multiple of len(control_nodes) = {len(nodes)} "
                         f"columns; got {columns}.")
    return nodes


def stage_nodes(nodes, n, columns):
    """`nodes` as a tuple of increasing step times in (0, 1), the last ``len(nodes) * n``
    of the `columns` of s."""
    nodes = tuple(float(c) for c in np.ravel(checks.real_array(
        "stage_nodes", nodes, "a sequence of step times in (0, 1)")))
    if not all(0.0 < c < 1.0 for c in nodes) or any(b <= a for a, b in zip(nodes, nodes[1:])):
        raise InputError(f"`stage_nodes` must increase within (0, 1); got {nodes}.")
    if len(nodes) * n > columns:
        raise InputError(f"`s` must hold the {len(nodes)} stage configurations of "
                         f"`stage_nodes` ({len(nodes) * n} columns); it has {columns}.")
    return nodes


def per_step(name, value, N):
    """A per-step array of shape (N, k); empty input (or None) means k = 0."""
    data = checks.real_array(name, np.zeros((N, 0)) if value is None else value,
                              f"an array of real numbers of shape ({N}, k)")
    if data.size == 0:
        data = data.reshape(N, 0) if N else np.zeros((0, data.shape[-1] if data.ndim == 2 else 0))
    if data.ndim != 2 or data.shape[0] != N:
        raise InputError(f"`{name}` must have shape ({N}, k), one row per step; got {data.shape}.")
    return checks.array(name, data, data.shape, allow_nan=True)


def assembled(t, q, p, lam, u, h, mu, s, final, memory=np.empty):
    """(t, q, p, lam, u, h, mu, s) of `Trajectory.assembled`: each array copied as a float
    array (of the last knot only when `final`), `mu` None as zeros, `h` a float; arrays of
    one run, or of runs along their leading axes (`Trajectory.assembled_runs`), then all
    copied into one buffer, ``memory(size)`` (a new array by default; numpy backs a large
    one with huge pages: far fewer new pages to fault in than one array per field)."""
    if final:
        t, q, p = t[..., -1:], q[..., -1:, :], p[..., -1:, :]
        lam, u, s = lam[..., :0, :], u[..., :0, :], s[..., :0, :]
    if mu is None:
        mu = np.zeros(lam.shape[:-2] + lam.shape[-1:])
    arrays = (t, q, p, lam, u, s, mu)
    if q.ndim == 2:
        copies = [np.array(a, dtype=float, order="C") for a in arrays]
    else:
        copies = copied_into(memory(sum(np.size(a) for a in arrays)), arrays)
    t, q, p, lam, u, s, mu = copies
    return t, q, p, lam, u, float(h), mu, s


def copied_into(buffer, arrays):
    """Views of consecutive pieces of the flat float array `buffer`, in order, each of the
    shape of one of `arrays` and holding a copy of its values (`buffer` at least as long
    as their sizes together)."""
    views, at = [], 0
    for a in arrays:
        views.append(buffer[at:at + np.size(a)].reshape(np.shape(a)))
        np.copyto(views[-1], a)
        at += np.size(a)
    return views


def node_tuples(control_nodes, stage_nodes):
    """The rules' nodes as tuples of floats, as `Trajectory.assembled` keeps them."""
    return tuple(tuple(float(c) for c in np.ravel(nodes)) for nodes in (control_nodes, stage_nodes))
