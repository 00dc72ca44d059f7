"""Figures of what a discretization keeps, the results stage of the pipeline: the discrete
constraint violation (28), the energy error of a free motion, the energy balance of a forced
one (E - E_0 - W, W the work of the discrete forces), and convergence plots.
"""

import numpy as np

from . import diagnostics
from ._canvas import finish, label, plain_log_ticks, single_axes
from .._util import checks
from ..principle.trajectory import check_trajectory


def _log_series(ax, t, values, name, empty="no values"):
    """Plot |values| on a log axis; exact zeros (invisible on it) are said in a note, and
    no values at all in the note `empty`."""
    values = np.abs(np.asarray(values, dtype=float))
    shown = np.where(values > 0, values, np.nan)
    ax.plot(t, shown, ".-" if t.size <= 200 else "-", ms=2, lw=0.8, label=name)
    ax.set_yscale("log")
    plain_log_ticks(ax)
    if not np.isfinite(shown).any():
        ax.text(0.5, 0.5, "identically zero" if values.size else empty,
                transform=ax.transAxes, ha="center")
        ax.set_ylim(1e-17, 1e-15)


def plot_constraint_violation(disc, traj, *, time_unit="", title=None, ax=None):
    """The violation max_a abs(omega_d^a(q_k, q_{k+1})) of (28) at each step, log scale.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory
    time_unit : str
        Unit of t for the axis label (a system's ``units["t"]``).
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = single_axes(ax)
    _log_series(ax, _midpoints(traj.t), diagnostics.constraint_violation(disc, traj),
                "max_a |omega_d^a(q_k, q_k+1)|")
    ax.set_xlabel(label("t", time_unit))
    ax.set_ylabel("constraint violation")
    return finish(fig, ax, title)


def plot_energy_error(disc, traj, *, energy_unit="", time_unit="", title=None, ax=None):
    """The energy error abs(E - E_0) on a log scale, E at the step midpoints
    (`diagnostics.energy`). A trajectory of one step has a single E and no change to show:
    the axes say so.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory
    energy_unit, time_unit : str
        Units for the axis labels (e.g. "J" and "s").
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = single_axes(ax)
    E = diagnostics.energy(disc, traj)
    _log_series(ax, _midpoints(traj.t)[1:], (E - E[0])[1:], "|E - E_0|",
                empty="one step: a single energy E_0, no change to show (needs 2 steps)")
    ax.set_xlabel(label("t", time_unit))
    ax.set_ylabel(label("energy error |E - E_0|", energy_unit))
    return finish(fig, ax, title)


def control_work(disc, traj):
    """The work W_k done by the discrete forces f_d^-/+ from the middle of step 0 to the
    middle of step k, shape (N,) (W_0 = 0): for a forced motion E_k - E_0 - W_k is what
    the discretization does not balance.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory

    Returns
    -------
    numpy.ndarray, shape (N,)

    Notes
    -----
    At the knot k the momentum jumps by the impulse f_d^+(step k-1) + f_d^-(step k); it
    works at the mean of the interpolant's velocities on both sides of the knot (for a
    linear rule the step velocities v_{k-1} and v_k = (q_{k+1} - q_k)/h). The impulses on
    a stage rule's stages work at the interpolant's velocity there, S_k in step k, half of
    it counted on each side of the step's middle:

        W_k - W_{k-1} = (f_d^+_{k-1} + f_d^-_k) . (v_{k-1}(1) + v_k(0))/2 + (S_{k-1} + S_k)/2.

    For the midpoint rule on a quadratic L with constant constraint one-forms (the LC
    circuit), E_k - E_0 - W_k vanishes to round-off (docs/stages/results.md); otherwise
    it is O(h^2) (measured: order 2 for the midpoint and trapezoid rules, 4 for Lobatto3,
    about 2 for Lobatto4, whose stages are not at the step's middle).
    """
    if not check_trajectory(disc, traj):
        return np.zeros(0)
    N, n = traj.steps, disc.system.n
    step = (traj.q[:-1].T, traj.q[1:].T, traj.s.T)
    f_minus, f_plus, f_stage = (np.array(f).T for f in disc.discrete_force.map(N)(
        *step, traj.u.T, traj.h))
    v = np.array(_node_velocities(disc).map(N)(*step, traj.h)).T.reshape(N, -1, n)
    stage_work = np.einsum("ksi,ksi->k", f_stage.reshape(N, -1, n), v[:, 1:-1])
    knots = np.einsum("ki,ki->k", f_plus[:-1] + f_minus[1:], (v[:-1, -1] + v[1:, 0]) / 2)
    return np.r_[0.0, np.cumsum(knots + (stage_work[:-1] + stage_work[1:]) / 2)]


def _node_velocities(disc):
    """``(q0, q1, s, h) -> v``: the interpolant's velocity at each node of the rule (0, the
    stages, 1), shape (n * nodes,), node by node."""
    import casadi as ca

    n, rule = disc.system.n, disc.rule
    q0, q1, s, h = ca.SX.sym("q0", n), ca.SX.sym("q1", n), ca.SX.sym("s", disc.n_stages), ca.SX.sym("h")
    v = [y for _, _, y, _ in rule.samples(q0, q1, s, h, points=[(c, 1.0) for c in rule.nodes])]
    return ca.Function("node_velocities", [q0, q1, s, h], [ca.vertcat(*v)], ["q0", "q1", "s", "h"], ["v"])


def plot_energy_balance(disc, traj, *, energy_unit="", time_unit="", title=None, ax=None):
    """The energy balance E_k - E_0 - W_k of a forced motion (`control_work`) against t,
    with the energy change E_k - E_0 it balances, on a linear scale.

    Parameters
    ----------
    disc : Discretization
    traj : Trajectory
    energy_unit, time_unit : str
        Units for the axis labels (e.g. "J" and "s").
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = single_axes(ax)
    E, W = diagnostics.energy(disc, traj), control_work(disc, traj)
    t = _midpoints(traj.t)
    if E.size < 2:
        ax.text(0.5, 0.5, "one step: a single energy E_0, no change to show (needs 2 steps)",
                transform=ax.transAxes, ha="center")
    balance = E - E[0] - W if E.size else E
    ax.plot(t, E - E[0] if E.size else E, color="0.6", lw=0.9, label="E - E_0")
    ax.plot(t, balance, color="C0", lw=1.2, label="balance E - E_0 - W"
            + (f" (max |.| {np.abs(balance).max():.1e})" if E.size else ""))
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel(label("t", time_unit))
    ax.set_ylabel(label("energy", energy_unit))
    return finish(fig, ax, title)


def plot_convergence(h, errors, *, order=None, ylabel="error", title=None, ax=None):
    """Error against step size h on log-log axes, with a reference slope `order`.

    Parameters
    ----------
    h, errors : array_like, shape (K,)
        Step sizes and the errors measured with them.
    order : float, optional
        Draw the line C h^order through the smallest h.
    ylabel : str
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    h = checks.vector("h", h)
    errors = checks.vector("errors", errors, h.size, allow_nan=True)
    order = None if order is None else checks.finite_float("order", order)
    fig, ax = single_axes(ax)
    ax.loglog(h, errors, "o-", label="measured")
    if order is not None:
        i = np.argmin(h)
        ax.loglog(h, errors[i] * (h / h[i]) ** order, "k--", lw=0.8, label=f"slope {order:g}")
    ax.set_xlabel("h")
    ax.set_ylabel(ylabel)
    return finish(fig, ax, title)


def plot_cost_convergence(steps, costs, *, title=None, ax=None):
    """Optimal cost against the number of steps N (log N axis).

    Parameters
    ----------
    steps, costs : array_like, shape (K,)
        Numbers of steps N and the optimal costs J_N obtained with them.
    title : str, optional
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    steps = checks.vector("steps", steps)
    costs = checks.vector("costs", costs, steps.size, allow_nan=True)
    fig, ax = single_axes(ax)
    ax.semilogx(steps, costs, "o-", label="optimal cost")
    ax.set_xlabel("N (steps)")
    ax.set_ylabel("cost")
    return finish(fig, ax, title)


def _midpoints(t):
    return (t[:-1] + t[1:]) / 2
