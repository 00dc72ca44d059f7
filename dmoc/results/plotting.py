"""Figures of computed trajectories, the results stage of the pipeline: the paths in the
plane with obstacles and goal, states and controls against time (one panel each, with
units and bounds), the discrete constraint violation (28), the energy error of a free
motion and the energy balance of a forced one, and convergence plots. matplotlib is
imported lazily; every function returns a `matplotlib.figure.Figure` (no pyplot state)
and never shows it.
"""

import os
import re

import numpy as np

from ._canvas import save_png
from .body_figure import plot_body, plot_body_rates
from .diagnostic_plots import (control_work, plot_constraint_violation, plot_convergence,
                               plot_cost_convergence, plot_energy_balance, plot_energy_error)
from .kept_out import kept_out_region
from .path_plot import plot_path
from .robot_figure import plot_robot
from .time_plots import plot_controls, plot_states
from .._util import checks
from .._util.files import make_folder
from ..discrete import Discretization
from ..errors import InputError
from ..optimal_control.statement.problem import OptimalControlProblem
from ..principle.trajectory import Trajectory

__all__ = ["plot_path", "plot_states", "plot_controls", "plot_constraint_violation",
           "plot_energy_error", "plot_energy_balance", "control_work", "plot_convergence",
           "plot_cost_convergence", "plot_robot", "plot_body", "plot_body_rates", "planes",
           "save_trajectory_plots"]


def planes(names):
    """The pairs of columns (x, y) of q that are positions in a plane, by name: "x", "y"
    and "x_<s>", "y_<s>" (several bodies); the default names q0, q1 give (0, 1).

    Parameters
    ----------
    names : sequence of str, shape (n,)

    Returns
    -------
    list of pair of int
        Empty when no coordinates name a plane (the LC circuit's charges).
    """
    names = list(names)
    found = [(i, names.index("y" + s[1:])) for i, s in enumerate(names)
             if re.fullmatch(r"x(_\w+)?", s) and "y" + s[1:] in names]
    default = len(names) >= 2 and names == [f"q{i}" for i in range(len(names))]
    return found or ([(0, 1)] if default else [])


def save_trajectory_plots(traj, out, name, *, disc=None, problem=None, names=None,
                          control_names=None, units=None, heading=None, goal=None,
                          obstacles=None):
    """Write the plots of `traj` as PNG files into the folder `out` (created if missing).

    Parameters
    ----------
    traj : Trajectory
    out : str or pathlib.Path
        Output folder, created with its missing parents; an InputError if it, or a folder
        above it, is a file.
    name : str
        Prefix of the files, without a path separator (the folders go into `out`):
        ``{name}_path.png`` (when coordinates name a plane, `planes`),
        ``{name}_states.png``, ``{name}_controls.png`` (when there are controls) and,
        given `disc`, ``{name}_constraint.png`` (when there are constraints) and
        ``{name}_energy.png`` (the energy error, or for a forced motion the balance
        E - E_0 - W).
    disc : Discretization, optional
        Needed for the constraint-violation and energy plots; its system gives the
        default `names` and `units`.
    problem : OptimalControlProblem, optional
        The problem `traj` solves: its discretization, goal and bounds are drawn, and,
        unless `obstacles` are given, the region of the first plane that its path
        constraints keep out (`kept_out_region`: the rows that read the plane's two
        coordinates alone).
    names, control_names : sequence of str, optional
        Names of the coordinates and of the controls; default the system's (`disc`'s).
    units : mapping, optional
        Units {"t", "q", "u"}; default the system's.
    heading : int, optional
        Column of q holding the heading (see `plot_path`).
    goal : array_like, shape (n,), optional
        Goal configuration drawn on the path; default the problem's.
    obstacles : array_like, shape (K, 3), or callable, optional
        Drawn on the path (see `plot_path`).

    The path plot draws the system's `bodies` at a few poses on the first plane.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    checks.instance("traj", traj, Trajectory, "a Trajectory")
    out = checks.file_path("out", out)
    checks.instance("name", name, str, "a str")
    if any(c in name for c in {"/", "\\", os.sep, os.altsep} - {None}):
        raise InputError(f"`name` must be a file-name prefix without a path separator; got "
                         f"{name!r} (give the folders in `out`, the prefix in `name`).")
    checks.instance("problem", problem, (OptimalControlProblem, type(None)),
                    "an OptimalControlProblem or None")
    disc = problem.disc if problem is not None and disc is None else disc
    checks.instance("disc", disc, (Discretization, type(None)), "a Discretization or None")
    system = disc.system if disc is not None else None
    names = names or (system.names if system else [f"q{i}" for i in range(traj.q.shape[1])])
    control_names = control_names or (system.control_names if system else None)
    units = units if units is not None else system.units if system else None
    goal = problem.q_goal if goal is None and problem is not None else goal
    out = make_folder("out", out)
    figures = _figures(traj, name, disc, problem, names, control_names, units, heading, goal,
                       obstacles)
    written = []
    for kind, fig in figures.items():
        written.append(out / f"{name}_{kind}.png")
        save_png(fig, written[-1])
    return written


def _figures(traj, name, disc, problem, names, control_names, units, heading, goal, obstacles):
    """{kind: Figure} of `save_trajectory_plots`."""
    figures, t_unit = {}, units["t"] if units else ""
    paths = planes(names)
    for i, (x, y) in enumerate(paths):
        if i == 0 and obstacles is None and problem is not None:
            obstacles = kept_out_region(problem, x, y)
        figures["path"] = plot_path(
            traj, x=x, y=y, heading=heading, goal=goal, labels=(names[x], names[y]),
            units=units, obstacles=obstacles if i == 0 else None, color=f"C{i}",
            bodies=disc.system.bodies if i == 0 and disc is not None else None,
            name=f"{names[x]}, {names[y]}" if len(paths) > 1 else "path",
            title=f"{name}: path", ax=figures["path"].axes[0] if i else None)
    figures["states"] = plot_states(traj, names=names, units=units, title=f"{name}: states",
                                    bounds=problem.state_bounds if problem else None)
    if traj.u.shape[1]:
        figures["controls"] = plot_controls(
            traj, names=control_names, units=units, title=f"{name}: controls",
            bounds=problem.control_bounds if problem else None)
    if disc is not None and traj.steps:
        if disc.system.m:
            figures["constraint"] = plot_constraint_violation(
                disc, traj, time_unit=t_unit, title=f"{name}: discrete constraint violation")
        if np.any(traj.u):
            figures["energy"] = plot_energy_balance(
                disc, traj, time_unit=t_unit,
                title=f"{name}: energy balance (W: work of the controls)")
        else:
            figures["energy"] = plot_energy_error(disc, traj, time_unit=t_unit,
                                                  title=f"{name}: energy error")
    return figures
