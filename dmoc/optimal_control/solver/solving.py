"""Consumer 2 of the step residual, its solver half: `solve` solves an
OptimalControlProblem with IPOPT (casadi.nlpsol, exact Hessian) from a guess, and returns
the optimal Trajectory, or raises SolverError carrying the last iterate and naming the most
violated constraint group (dynamics at step k, boundary, path). `dmoc.optimize` is this
solve followed by the verdict of `dmoc.drivers.verdict`.
"""

import math
import sys
import time
import warnings

import numpy as np

from ..._util import checks
from ..._util.deferred import Pending
from ..statement.problem import OptimalControlProblem
from ...errors import DmocDeprecationWarning, InputError, Status, failure
from . import interrupt
from .fixed_multipliers import deferred as deferred_lam_x, fixed_entries
from .guess import start_point
from .linear_solver_choice import check_linear_solver
from .newton_kkt import NEWTON_OPTIONS, applies, newton_resolve
from ..nlp.evaluation import compiled_when_ready, spent
from .ipopt import DEFAULT_IPOPT_OPTIONS, data_tolerances, iteration_count, linear_algebra, start_options
from .ipopt import solver as ipopt_solver
from . import linear_solver
from .optimization_result import OptimizationResult
from .violation import most_violated, worst
from ...principle.trajectory import Trajectory


# dmoc's own switches of `optimize` and their defaults; given as entries of `options` they
# are taken out with a DeprecationWarning naming the keyword
SWITCHES = {"reuse_solver": True, "expand": False, "linear_solver_report": False}


def solve(problem, *, guess=None, options=None, reuse_solver=True, expand=False,
          linear_solver_report=False, jit=None, throw=True):
    """Solve a DMOC problem with IPOPT, without judging the optimum: `dmoc.optimize` with
    ``check=False``, whose docstring gives the parameters.

    Returns
    -------
    OptimizationResult
        Its `success` is IPOPT's; its `verdict` None.
    """
    checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
    throw = checks.boolean("throw", throw)
    jit = None if jit is None else checks.boolean("jit", jit)
    checks.instance("guess", guess, (Trajectory, OptimizationResult, type(None)),
                    "a Trajectory, an OptimizationResult or None")
    options = None if options is None else checks.ipopt_options("options", options)
    check_linear_solver(options or {})
    options, switches = _switches(options or {}, {"reuse_solver": reuse_solver, "expand": expand,
                                                  "linear_solver_report": linear_solver_report})
    T = problem.transcription
    D, R = T.x_scale, T.g_scale      # IPOPT iterates on x / D, imposes R g
    lbx, ubx = T.lbx / D, T.ubx / D
    fixed = fixed_entries(lbx, ubx)
    x0, lam_x0, lam_g0 = start_point(problem, guess, fixed)
    x0 = x0 / D        # scaled: IPOPT and the data's tolerances read it
    warm = isinstance(guess, OptimizationResult) and lam_g0 is guess.lam_g
    automatic = jit is None     # compiled once the structure is re-solved, when the library is ready
    if automatic:
        jit = compiled_when_ready(T.separable, warm)
    tic = time.perf_counter()
    raised = data_tolerances(T, x0, jit)
    tolerances = {**DEFAULT_IPOPT_OPTIONS, **raised, **options}
    solver, reused, journal = ipopt_solver(
        T, {**raised, **start_options(warm), **options},
        expand=switches["expand"], reuse=switches["reuse_solver"],
        report=switches["linear_solver_report"], jit=jit)
    times = {"build_time": 0.0 if reused else time.perf_counter() - tic, "solver_reused": reused,
             "warm_start": warm, "compiled": jit}
    journal_start = linear_solver.journal_end(journal) if journal else 0
    bounds = (lbx, ubx, *T.scaled_g_bounds)
    tic = time.perf_counter()
    newton = (newton_resolve(T, x0, lam_g0 / R, bounds, fixed, (tolerances["tol"], tolerances["constr_viol_tol"]))
              if warm and options.keys() <= NEWTON_OPTIONS and not journal and applies(T, *bounds) else None)
    if newton is None:
        with interrupt.watch() as sigints:
            sol = solver(x0=x0, p=T.p, lam_x0=lam_x0 * D, lam_g0=lam_g0 / R,
                         lbx=lbx, ubx=ubx, lbg=bounds[2], ubg=bounds[3])
        st = solver.stats()
    else:
        sol, iterations, times["newton_time"] = newton
        sigints, st = [], {"success": True, "return_status": "Solve_Succeeded", "iter_count": iterations,
                           "iterations": {"regularization_size": [0.0] * iterations}, "t_wall_total": 0.0}
    times["solve_time"] = time.perf_counter() - tic
    times["nlp_solver"] = "ipopt" if newton is None else "newton"
    cost, worst = values_at_x(T, sol, st["success"])
    stats = _statistics(st, times, worst)
    if automatic and warm and not jit:
        spent(T.separable, stats["ipopt_time"] if newton is None else stats["newton_time"])
    if journal:
        stats["linear_solver"] = linear_solver.linear_solver_report(journal, journal_start)
    status, message, success = _outcome(st, stats, cost, sigints)
    result = _result(problem, solver, sol, fixed, (cost, success, status, message, stats))
    if not success and throw:
        raise failure(message + " The last iterate is in `.result`.", result)
    return result


def _statistics(st, times, worst):
    """A result's `stats` from IPOPT's statistics `st`, the build and solve `times`
    ({"build_time", "solver_reused", "warm_start", "solve_time"}) and the most violated
    row `worst` (`most_violated`)."""
    return {"iterations": iteration_count(st), "return_status": st["return_status"], **times,
            "ipopt_time": st.get("t_wall_total", times["solve_time"]),
            "ipopt_cpu_time": st.get("t_proc_total", 0.0), **linear_algebra(st),
            "max_violation": worst[0], "most_violated": worst[1]}


def _outcome(st, stats, cost, sigints):
    """(status, message, success) of a solve from IPOPT's statistics `st` and the result's
    `stats`: IPOPT's, with what the status suggests; "interrupted" when a Ctrl-C
    (`sigints`), not a violated constraint, ended it."""
    iterations = stats["iterations"]
    where = f"; most violated: {stats['most_violated']} (|violation| = {stats['max_violation']:.2e})"
    if st["return_status"] == "Invalid_Number_Detected":
        where = ("; an NLP function (dynamics, cost or their derivatives) returned NaN or Inf "
                 "at the start point or an iterate: check the data's scale (h, bounds) and "
                 "the system's functions there")
    elif st["return_status"] == "Invalid_Option":
        where = _REFUSED_OPTION
    stopped = interrupt.verdict(sigints, iterations, cost)
    if stopped:
        return stopped + (False,)
    solver = "IPOPT" if stats["nlp_solver"] == "ipopt" else "Newton's method on the KKT conditions"
    return (st["return_status"], f"{solver}: {st['return_status']} after {iterations} iterations, "
            f"cost {cost:.10g}{where}.", bool(st["success"]))


def _result(problem, solver, sol, fixed, outcome):
    """The OptimizationResult of the packed call's output `sol` of `solver` on `problem`,
    whose fixed entries are `fixed`, with `outcome` (cost, success, status, message,
    stats): x, lam_x and lam_g unscaled, as the packed call forms them; the trajectory made
    on first access when x is finite (its 1-norm is; `OptimizationResult.trajectory`; the
    copy keeps it from writes into result.x), and lam_x completed on first access
    (`fixed_multipliers.deferred`)."""
    T = problem.transcription
    x, lam_x = sol["result_x"], sol["result_lam_x"]
    traj = Pending(trajectory_from_x, problem, x.copy()) if math.isfinite(sol["x_norm1"][0]) else \
        trajectory_from_x(problem, x)
    if solver.fixed_multipliers is not None:
        scaled = (sol["x"], T.p, sol["lam_g"], T.x_scale)
        lam_x = deferred_lam_x(solver.fixed_multipliers, lam_x, fixed, scaled)
    return OptimizationResult(traj, *outcome, x, lam_x, sol["result_lam_g"], T.structure, T.q_ref.copy())


def values_at_x(transcription, sol, converged):
    """(f, (largest violation, its row described)) of the NLP at the x IPOPT returned in
    `sol` (`ipopt.PackedSolver`'s outputs): IPOPT's own last f, and the largest violation
    at its last g that the packed call found, when they were evaluated at that x, else f
    and g evaluated anew (`most_violated`). They are IPOPT's when it converged and no
    entry of x with lbx < ubx sits on a bound (sol["on_bound"] is 0):
    honor_original_bounds (and CasADi's bound_consistency) move x onto its bounds after
    IPOPT's last f and g (h at T_min/N or T_max/N with a free final time), and an iterate
    of the interior-point method touches none of its bounds."""
    T = transcription
    if converged and not sol["on_bound"][0]:
        return float(sol["f"][0]), worst(T, sol["largest"][0], sol["row"][0])
    cost, g = T.separable.values(sol["x"], T.p)
    return cost, most_violated(T, g / T.g_scale)


# the hint of an Invalid_Option status: IPOPT refused an option value when the solve started
# (before any iterate, so no constraint is to blame; an unavailable linear solver is refused
# before: `check_linear_solver`)
_REFUSED_OPTION = ("; IPOPT refused an option value of `options` when the solve started (see "
                   "IPOPT's output above for which); no iterate was computed")


def _switches(options, given):
    """(the IPOPT options, {switch: bool}): the `SWITCHES` keywords of `optimize` as
    `given`, an entry of `options` of that name taken out instead with a
    DmocDeprecationWarning (InputError when the keyword says otherwise)."""
    options, switches = dict(options), {}
    for name, default in SWITCHES.items():
        value = given[name]
        if name in options:
            entry = options.pop(name)
            warnings.warn(f"`options['{name}']` is deprecated: pass `{name}={entry!r}` to "
                          f"`optimize` instead; `options` holds IPOPT's options only.",
                          DmocDeprecationWarning, stacklevel=_caller_level())
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


def trajectory_from_x(problem, x):
    """The Trajectory held in an NLP vector x of `problem`. When x and its momenta are
    finite (an optimum, any iterate short of an overflow), every check of
    ``Trajectory(...)`` holds by construction, so its fields are made as that constructor
    makes them, without the checks (`Trajectory.assembled`);
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
