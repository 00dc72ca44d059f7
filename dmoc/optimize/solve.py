"""Consumer 2 of the step residual, its solver half: `solve` solves an
OptimalControlProblem with IPOPT (casadi.nlpsol, exact Hessian) from a guess, and returns
the optimal Trajectory, or raises SolverError carrying the last iterate and naming the most
violated constraint group (dynamics at step k, boundary, path). `dmoc.optimize` is this
solve followed by the verdict of `dmoc.results.verdict`.
"""

import json
import sys
import time
import warnings
from dataclasses import dataclass, field, fields

import numpy as np

from .._util import checks
from .._util.deferred import DeferredField, Pending, made
from .problem import OptimalControlProblem
from ..errors import InputError, Interrupted, SolverError, TrajectoryFileError
from . import interrupt
from .fixed_multipliers import deferred as deferred_lam_x, fixed_entries
from .guess import start_point
from .._util.files import atomic_write, writable_file
from .ipopt import data_tolerances, iteration_count, linear_algebra, start_options
from .ipopt import solver as ipopt_solver
from . import linear_solver
from ..principle.trajectory import RESULT_PREFIX, Trajectory, read
from .verdict import Verdict


@dataclass
class OptimizationResult:
    """Outcome of `dmoc.optimize` (and of the raw IPOPT `solve`).

    Attributes
    ----------
    trajectory : Trajectory
        The optimal trajectory, or the last iterate when not `success`. A solve whose x is
        finite makes it from `x` on first access (the same fields, bit for bit, as when
        made at once) and keeps it: a re-solve whose caller reads only x, the
        multipliers and the cost (a warm start) does not pay its momenta and arrays (0.1-0.2
        ms at N = 11-28, docs/performance.md). A pickle or copy holds it made.
    cost : float
    success : bool
        IPOPT converged and, for `dmoc.optimize` with ``check=True``, the verdict passed.
    status : str
        IPOPT's return status, e.g. ``"Solve_Succeeded"``, ``"interrupted"`` when a
        Ctrl-C (SIGINT) stopped IPOPT, or the status of a failed verdict
        (``"not_replayable"``, ``"path_violated"``, ``"under_resolved"``);
        ``stats["return_status"]`` keeps IPOPT's own.
    message : str
    stats : dict
        ``iterations``, ``return_status``, ``build_time`` (seconds to create the solver; 0
        when a solver of the same structure and options was reused), ``solver_reused``,
        ``warm_start`` (True when IPOPT started from a previous optimum's x and
        multipliers), ``solve_time`` (wall seconds of the solver call), ``ipopt_time`` (of them
        the seconds in CasADi's IPOPT call itself, as CasADi records them: without the
        conversions of the inputs and outputs), ``function_time`` (the part
        of it spent evaluating the NLP functions and derivatives; the rest is mostly the
        linear solver), ``regularized_iterations`` and ``max_regularization`` (iterations
        whose KKT matrix had the wrong inertia and the largest Hessian shift delta_w IPOPT
        added), ``max_violation`` (of all constraints), ``most_violated`` (group, step, row),
        and with ``linear_solver_report=True`` ``linear_solver``
        (`dmoc.optimize.linear_solver.linear_solver_report`).
    x : ndarray, shape (problem.x_layout.size,)
        The NLP vector in the system's units (IPOPT's iterate times ``problem.x_scale``);
        ``problem.x_layout.unpack(x, name)`` reads any block (e.g. the end impulse
        ``"nu"``); its block "q" holds q - q_ref (``problem.configurations(x)`` gives q).
    lam_x, lam_g : ndarray, shapes like x and like problem.g_layout
        IPOPT's multipliers of the bounds and of the constraints at `x`, converted to the
        unscaled NLP (``lam_x = lam_x_ipopt / x_scale``, ``lam_g = g_scale * lam_g_ipopt``).
        The entries of lam_x whose bounds are equal (the given boundary data) are made on
        first access, as IPOPT's ``fixed_variable_treatment`` "make_parameter" makes them
        (`dmoc.optimize.fixed_multipliers`; a warm start from the result does not read them).
    structure : str
        The problem's `structure` key: a result warm-starts (primal and dual) any problem
        with the same key, e.g. one from ``problem.with_boundary(...)``.
    q_ref : ndarray, shape (n,)
        The problem's `q_ref`, on which `x` is centered.
    verdict : Verdict or None
        The figures of `dmoc.optimize`'s checks (`dmoc.optimize.Verdict`); None when the
        optimum was not judged (``check=False``, the raw `solve`, or IPOPT did not converge).
    """

    trajectory: Trajectory = DeferredField()
    cost: float
    success: bool
    status: str
    message: str
    stats: dict = field(default_factory=dict)
    x: np.ndarray = None
    lam_x: np.ndarray = DeferredField(None)
    lam_g: np.ndarray = None
    structure: str = ""
    q_ref: np.ndarray = None
    verdict: Verdict = None

    def __getstate__(self):
        """The fields, the trajectory made: a pickle or copy holds no pending computation
        (nor the problem it reads)."""
        return made(self)

    def save(self, path):
        """Write the result to an uncompressed .npz file at exactly `path`: the trajectory's
        fields (so `Trajectory.load` reads it too), x, the multipliers, cost, status,
        message, structure, stats and the verdict (as JSON)."""
        traj = {f.name: np.asarray(getattr(self.trajectory, f.name)) for f in fields(Trajectory)}
        extra = {RESULT_PREFIX + k: np.asarray(getattr(self, k))
                 for k in ("cost", "success", "status", "message", "x", "lam_x", "lam_g", "structure",
                           "q_ref") if getattr(self, k) is not None}
        extra[RESULT_PREFIX + "stats"] = json.dumps(self.stats, default=str)
        if self.verdict is not None:
            extra[RESULT_PREFIX + "verdict"] = json.dumps(self.verdict.as_dict())
        path = writable_file("path", checks.file_path("path", path))
        with atomic_write(path) as file:
            np.savez(file, **traj, **extra)

    @classmethod
    def load(cls, path):
        """Read a result written by `save`; ``optimize(problem, guess=loaded)`` warm-starts
        as from the result itself.

        Raises
        ------
        MissingFileError
            If there is no file at `path` (a FileNotFoundError).
        TrajectoryFileError
            If the file is not a trajectory file (`Trajectory.load`), or is one without the
            result's fields (written by `Trajectory.save`, not `OptimizationResult.save`).
        """
        traj = read(Trajectory, path, RESULT_FILE)      # checks the path, that it is an .npz
        with np.load(path, allow_pickle=False) as data:
            extra = {k[len(RESULT_PREFIX):]: data[k] for k in data.files if k.startswith(RESULT_PREFIX)}
        missing = sorted(_RESULT_FIELDS - set(extra))
        if missing:
            raise TrajectoryFileError(
                f"{str(path)!r} is not {RESULT_FILE}: it lacks the fields {missing}"
                + ("; it is a trajectory file (read it with Trajectory.load)." if len(missing) ==
                   len(_RESULT_FIELDS) else "."))
        verdict = extra.get("verdict")      # files of unjudged results have none
        return cls(traj, float(extra["cost"]), bool(extra["success"]),
                   str(extra["status"]), str(extra["message"]), json.loads(str(extra["stats"])),
                   extra.get("x"), extra.get("lam_x"), extra.get("lam_g"), str(extra["structure"]),
                   extra.get("q_ref"),        # files from before q_ref have none
                   None if verdict is None else Verdict.from_dict(json.loads(str(verdict))))


RESULT_FILE = "an optimization result file (one written by OptimizationResult.save)"
# the fields every `OptimizationResult.save` writes (x and the multipliers only when known)
_RESULT_FIELDS = {"cost", "success", "status", "message", "stats", "structure"}


# dmoc's own switches of `optimize` and their defaults; given as entries of `options` they
# are taken out with a DeprecationWarning naming the keyword
SWITCHES = {"reuse_solver": True, "expand": False, "linear_solver_report": False}


def solve(problem, *, guess=None, options=None, reuse_solver=True, expand=False,
          linear_solver_report=False, jit=False, throw=True):
    """Solve a DMOC problem with IPOPT, without judging the optimum: `dmoc.optimize` with
    ``check=False``, whose docstring gives the parameters.

    Returns
    -------
    OptimizationResult
        Its `success` is IPOPT's; its `verdict` None.
    """
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    throw, jit = checks.boolean("throw", throw), checks.boolean("jit", jit)
    checks.instance("guess", guess, (Trajectory, OptimizationResult, type(None)),
                    "a Trajectory, an OptimizationResult or None")
    options = None if options is None else checks.ipopt_options("options", options)
    options, switches = _switches(options or {}, {"reuse_solver": reuse_solver, "expand": expand,
                                                  "linear_solver_report": linear_solver_report})
    T = problem.transcription
    D, R = T.x_scale, T.g_scale      # IPOPT iterates on x / D, imposes R g
    lbx, ubx = T.lbx / D, T.ubx / D
    fixed = fixed_entries(lbx, ubx)
    x0, lam_x0, lam_g0 = start_point(problem, guess, fixed)
    x0 = x0 / D        # scaled: IPOPT and the data's tolerances read it
    warm = isinstance(guess, OptimizationResult) and lam_g0 is guess.lam_g
    tic = time.perf_counter()
    solver, reused, journal = ipopt_solver(
        T, {**data_tolerances(T, x0, jit), **start_options(warm), **options},
        expand=switches["expand"], reuse=switches["reuse_solver"],
        report=switches["linear_solver_report"], jit=jit)
    build_time = time.perf_counter() - tic
    journal_start = linear_solver.journal_end(journal) if journal else 0
    tic = time.perf_counter()
    with interrupt.watch() as sigints:
        sol = solver(x0=x0, p=T.p, lam_x0=lam_x0 * D, lam_g0=lam_g0 / R,
                     lbx=lbx, ubx=ubx, lbg=T.scaled_g_bounds[0], ubg=T.scaled_g_bounds[1])
    solve_time = time.perf_counter() - tic
    x = D * sol["x"]
    st = solver.stats()
    cost, g = _values_at_x(T, sol, (lbx, ubx), st["success"])
    worst = most_violated(T, g / R)
    stats = {"iterations": iteration_count(st), "return_status": st["return_status"],
             "build_time": 0.0 if reused else build_time, "solver_reused": reused,
             "warm_start": warm,
             "solve_time": solve_time, "ipopt_time": st.get("t_wall_total", solve_time),
             **linear_algebra(st),
             "max_violation": worst[0], "most_violated": worst[1]}
    if journal:
        stats["linear_solver"] = linear_solver.linear_solver_report(journal, journal_start)
    # made on first access when x is finite (`OptimizationResult.trajectory`); the copy
    # keeps it from writes into result.x
    traj = Pending(trajectory_from_x, problem, x.copy()) if np.isfinite(x).all() else \
        trajectory_from_x(problem, x)
    success = bool(st["success"])
    where = f"; most violated: {worst[1]} (|violation| = {worst[0]:.2e})"
    if st["return_status"] == "Invalid_Number_Detected":
        where = ("; an NLP function (dynamics, cost or their derivatives) returned NaN or Inf "
                 "at the start point or an iterate: check the data's scale (h, bounds) and "
                 "the system's functions there")
    elif st["return_status"] == "Invalid_Option":
        where = _refused_option(options)
    message = (f"IPOPT: {st['return_status']} after {stats['iterations']} iterations, "
               f"cost {cost:.10g}{where}.")
    status, stopped = st["return_status"], interrupt.verdict(sigints, stats["iterations"], cost)
    if stopped:     # a Ctrl-C, not a violated constraint, ended the solve
        (status, message), success = stopped, False
    lam_x = sol["lam_x"] / D if solver.fixed_multipliers is None else deferred_lam_x(
        solver.fixed_multipliers, sol["lam_x"] / D, fixed, (sol["x"], T.p, sol["lam_g"], D))
    result = OptimizationResult(traj, cost, success, status, message, stats,
                                x, lam_x, R * sol["lam_g"], T.structure, T.q_ref.copy())
    if stopped and throw:
        raise Interrupted(message + " The last iterate is in `.result`.", result)
    if not success and throw:
        raise SolverError(message + " The last iterate is in `.result`.", result)
    return result


def _values_at_x(transcription, sol, bounds, converged):
    """(f, g) of the scaled NLP at the x IPOPT returned in `sol`: IPOPT's own last f and g
    when they were evaluated there, else evaluated anew. They are IPOPT's when it
    converged and no entry of x with lbx < ubx (the scaled `bounds`) sits on a bound:
    honor_original_bounds (and CasADi's bound_consistency) move x onto its bounds after
    IPOPT's last f and g (h at T_min/N or T_max/N with a free final time), and an iterate
    of the interior-point method touches none of its bounds."""
    lbx, ubx = bounds
    x = sol["x"]
    on_bound = (lbx < ubx) & ((x == lbx) | (x == ubx))
    if converged and not on_bound.any():
        return float(sol["f"][0]), sol["g"]
    return transcription.separable.values(x, transcription.p)


def _refused_option(options):
    """The hint of an Invalid_Option status: IPOPT refused an option value when the solve
    started (before any iterate, so no constraint is to blame)."""
    solver = options.get("linear_solver")
    if solver is not None and str(solver).lower() != "mumps":
        return (f"; IPOPT refused the option `linear_solver` = {solver!r}: that linear solver "
                f"is not available to this IPOPT, which has 'mumps' (the HSL solvers "
                f"ma27, ma57, ma77, ma86, ma97 need the HSL library installed where IPOPT "
                f"finds it); leave `linear_solver` unset for MUMPS")
    return ("; IPOPT refused an option value of `options` when the solve started (see "
            "IPOPT's output above for which); no iterate was computed")


def _switches(options, given):
    """(the IPOPT options, {switch: bool}): the `SWITCHES` keywords of `optimize` as
    `given`, an entry of `options` of that name taken out instead with a
    DeprecationWarning (InputError when the keyword says otherwise)."""
    options, switches = dict(options), {}
    for name, default in SWITCHES.items():
        value = given[name]
        if name in options:
            entry = options.pop(name)
            warnings.warn(f"`options['{name}']` is deprecated: pass `{name}={entry!r}` to "
                          f"`optimize` instead; `options` holds IPOPT's options only.",
                          DeprecationWarning, stacklevel=_caller_level())
            if value != default and entry != value:
                raise InputError(f"`{name}` is given twice with different values: `{name}="
                                 f"{value!r}` and `options['{name}']` = {entry!r}; pass the "
                                 f"keyword alone.")
            value = entry
        switches[name] = checks.boolean(name, value)
    return options, switches


def _caller_level():
    """The `stacklevel` of a warning that names the first caller outside dmoc (through
    `dmoc.optimize` or `solve`)."""
    level, frame = 1, sys._getframe(1)
    while frame is not None and frame.f_globals.get("__name__", "").startswith("dmoc."):
        level, frame = level + 1, frame.f_back
    return level


def most_violated(transcription, g):
    """(largest bound violation, its description) over the constraint vector g of
    `transcription`."""
    violation = np.maximum(transcription.lbg - g, g - transcription.ubg)
    violation = np.where(np.isnan(violation), np.inf, np.maximum(violation, 0.0))
    if violation.size == 0:
        return 0.0, "none"
    i = int(np.argmax(violation))
    group, row, col = transcription.g_layout.locate(i)
    if group == "dynamics":
        name, row_in_block, _ = transcription.dynamics_rows.locate(row)     # blocks of one column
        return float(violation[i]), f"dynamics at step {col} ({name} row {row_in_block})"
    if group == "path":
        return float(violation[i]), f"path constraint {row} at step {col}"
    if group == "path_knots":
        return float(violation[i]), f"path constraint {transcription.path_knot_rows[row]} at knot {col}"
    return float(violation[i]), f"boundary condition '{group}' row {row}"


def trajectory_from_x(problem, x):
    """The Trajectory held in an NLP vector x of `problem`. When x and its momenta are
    finite (an optimum, any iterate short of an overflow), every check of
    ``Trajectory(...)`` holds by construction, so its fields are made as that constructor
    makes them, without the checks (`Trajectory.assembled`, about 0.1 ms less per solve);
    otherwise the checking constructor refuses or keeps them as before."""
    T, N = problem.transcription, problem.steps
    lay, rule = T.x_layout, problem.disc.rule
    h = problem.final_time.step(lay, x)
    mu = lay.unpack(x, "mu")[:, 0] if lay.numel("mu") else np.zeros(problem.disc.system.m)
    fields = [h * np.arange(N + 1), T.configurations(x), T.momenta(x), lay.unpack(x, "lam").T,
              lay.unpack(x, "u").T, h, problem.formulation.name, mu, lay.unpack(x, "s").T,
              rule.control_nodes, rule.stage_nodes]
    if not (np.isfinite(x).all() and np.isfinite(fields[2]).all() and h > 0):
        return Trajectory(*fields)
    return Trajectory.assembled(*fields)
