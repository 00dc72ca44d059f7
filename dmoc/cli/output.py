"""What ``--out`` and ``--animate`` write: the trajectory as .npz (exact, `Trajectory.load`)
and as .csv with named columns (and how ``simulate --controls`` reads that table back), a
JSON summary, the plots and the GIF.
"""

import json
import math
import time

import numpy as np

from ..errors import InputError
from ..results import diagnostics
from .._util.files import atomic_write, write_text
from ..results.animation import animate
from ..results.kept_out import kept_out_region
from ..results.plotting import planes, save_trajectory_plots


def energy_drift(disc, traj):
    """max_k |E_k - E_0| over the step-midpoint energies (0 for fewer than two steps)."""
    E = diagnostics.energy(disc, traj)
    return float(np.abs(E - E[0]).max()) if E.size else 0.0


def csv_columns(traj, names, control_names):
    """Column names and the (N+1, columns) table: t, q, p at the knots; lam and u of step
    k on row k (the last row holds NaN there: there is no step after t_N). Controls at a
    stage rule's nodes are named by node, e.g. ``force@0.5`` (the step time t_k + 0.5 h)."""
    def per_step(a):
        return np.vstack([a, np.full((1, a.shape[1]), np.nan)])

    nodes = traj.control_nodes
    controls = list(control_names) if nodes == (0.5,) else [
        f"{name}@{c:.4g}" for c in nodes for name in control_names]
    header = (["t", *names, *(f"p_{s}" for s in names),
               *(f"lam_{a}" for a in range(traj.lam.shape[1])), *controls])
    table = np.column_stack([traj.t, traj.q, traj.p, per_step(traj.lam), per_step(traj.u)])
    return header, table


def run_table(header, table, names):
    """{"t", "q", "p", "u"} of a table of `csv_columns` with the `header` and rows `table`,
    written for the coordinates `names`: t shape (N+1,), q and p (N+1, n), u (N, columns),
    the controls of the steps (the last row, after t_N, dropped). The knots must be evenly
    spaced, as a step h of the replay needs."""
    n, table = len(names), np.atleast_2d(table)
    coordinates = ["t", *names, *(f"p_{s}" for s in names)]
    if header[:2 * n + 1] != coordinates:
        raise InputError(f"its columns start {','.join(header[:2 * n + 1])}; a table of this "
                         f"system starts {','.join(coordinates)} (written for another system?)")
    controls = 2 * n + 1 + sum(name.startswith("lam_") for name in header[2 * n + 1:])
    if table.shape[1] != len(header) or len(table) < 2:
        raise InputError(f"it needs rows of {len(header)} numbers, one per knot, at least 2; "
                         f"got shape {table.shape}")
    t = table[:, 0]
    if not np.allclose(np.diff(t), (t[-1] - t[0]) / (len(t) - 1), rtol=1e-9, atol=0.0):
        raise InputError("its times t are not evenly spaced (a replay needs one step h)")
    return {"t": t, "q": table[:, 1:n + 1], "p": table[:, n + 1:2 * n + 1],
            "u": table[:-1, controls:]}


BLOCK = 65536               # rows of the table formatted at once
PROGRESS_SECONDS = 2.0      # between two messages of a long table's progress


def write_table(file, header, table, progress, shown):
    """Write the header line and the rows of `table` (17 significant digits: exact) to the
    text `file`, block by block, telling `progress` (if given) every PROGRESS_SECONDS how
    far it is (a table of 10**7 rows takes minutes; `shown` names it)."""
    file.write(",".join(header) + "\n")
    last = time.monotonic()
    for start in range(0, len(table), BLOCK):
        np.savetxt(file, table[start:start + BLOCK], delimiter=",", fmt="%.17g")
        if progress is not None and time.monotonic() - last > PROGRESS_SECONDS:
            last = time.monotonic()
            progress(f"writing {shown}: {min(start + BLOCK, len(table))} of {len(table)} rows")


def json_value(value):
    """JSON-safe values: non-finite floats become null (strict JSON has no inf or NaN)."""
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    return value


# every file a run named NAME may write: NAME.npz, .csv, _summary.json, .gif and the kinds
# of `save_trajectory_plots`
_SUFFIXES = (".npz", ".csv", "_summary.json", ".gif", "_path.png", "_states.png",
             "_controls.png", "_constraint.png", "_energy.png")


def run_files(name):
    """The names of every file a run named `name` may write: an earlier run's set, which a
    new run replaces as a whole (a file the new run does not write again is removed)."""
    return [name + suffix for suffix in _SUFFIXES]


def write_all(out, name, disc, traj, summary, spec, *, names, control_names, goal=None,
              gif=False, plots=True, problem=None, progress=None):
    """Write every output file of one run into `out` (the trajectory, table and summary,
    and, for a finite trajectory, the plots if `plots` and the GIF if `gif`); return the
    paths written. Given the `problem` an optimum solves, its bounds are drawn, and what its
    path constraints keep out of the plane; the GIF draws the system's bodies (a stock
    `spec.shape` when it declares none, or when its coordinates name no plane); `progress`
    (a function of a message) hears how far a long table is written."""
    written = [out / f"{name}.npz", out / f"{name}.csv", out / f"{name}_summary.json"]
    traj.save(written[0])
    header, table = csv_columns(traj, names, control_names)
    with atomic_write(written[1], "w") as file:
        write_table(file, header, table, progress, f"{name}.csv")
    write_text(written[2], json.dumps({k: json_value(v) for k, v in summary.items()},
                                      indent=2) + "\n")
    if not np.isfinite(traj.q).all():
        return written
    if plots:
        written += save_trajectory_plots(traj, out, name, disc=disc, problem=problem,
                                         names=names, control_names=control_names,
                                         heading=spec.heading, goal=goal)
    if gif and traj.q.shape[1] >= 2:
        x, y = (planes(names) or [(0, 1)])[0]
        bodies = disc.system.bodies if planes(names) else ()
        written.append(animate(traj, out / f"{name}.gif", bodies=bodies or None,
                               shape=None if bodies else spec.shape, x=x, y=y,
                               heading=spec.heading, roll=spec.roll, goal=goal,
                               obstacles=problem and kept_out_region(problem, x, y),
                               labels=(names[x], names[y]), units=disc.system.units,
                               title=name))
    return written
