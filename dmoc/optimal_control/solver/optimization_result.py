"""Consumer 2 of the step residual, its outcome: `OptimizationResult`, what `solve` and
`dmoc.optimize` return (the optimal Trajectory, made on first access, IPOPT's x and
multipliers in the system's units, the cost, status, stats and verdict), and its file:
`OptimizationResult.save` writes it as .npz, `OptimizationResult.load` reads it back so that
it warm-starts a solve as the result itself does.
"""

import json
from dataclasses import dataclass, field

import numpy as np

from ..._util.deferred import DeferredField, made
from ...errors import InputError, TrajectoryFileError, status_of
from ...principle.rotation_trajectory import RotationTrajectory
from ...principle.trajectory import Trajectory
from ...principle.trajectory_file import RESULT_PREFIX, read, scalar, write
from .verdict_record import Verdict


@dataclass
class OptimizationResult:
    """Outcome of `dmoc.optimize` (and of the raw IPOPT `solve`).

    Attributes
    ----------
    trajectory : Trajectory or RotationTrajectory
        The optimal trajectory, or the last iterate when not `success` (a
        RotationTrajectory for a `GroupOptimalControlProblem`). A solve whose x is
        finite makes it from `x` on first access (the same fields, bit for bit, as when
        made at once) and keeps it: a re-solve whose caller reads only x, the
        multipliers and the cost (a warm start) does not pay its momenta and arrays
        (benchmarks/peers.py resolve). A pickle or copy holds it made.
    cost : float
    success : bool
        IPOPT converged and, for `dmoc.optimize` with ``check=True``, the verdict passed.
    status : dmoc.Status or str
        IPOPT's return status, a plain str (e.g. ``"Solve_Succeeded"``), or a `Status`:
        ``"interrupted"`` when a Ctrl-C (SIGINT) stopped IPOPT, the status of a failed
        verdict (``"not_replayable"``, ``"path_violated"``, ``"under_resolved"``) or
        ``"accuracy_not_reached"``; ``stats["return_status"]`` keeps IPOPT's own.
    message : str
    stats : dict
        ``iterations``, ``return_status``, ``build_time`` (seconds to create the solver; 0
        when a solver of the same structure and options was reused), ``solver_reused``,
        ``warm_start`` (True when IPOPT started from a previous optimum's x and
        multipliers), ``compiled`` (True when IPOPT evaluated the NLP as compiled C: with
        ``jit=True``, or by default once the structure's background compile had finished),
        ``solve_time`` (wall seconds of the solver call), ``ipopt_time`` (of them
        the seconds in CasADi's IPOPT call itself, as CasADi records them: without the
        conversions of the inputs and outputs), ``ipopt_cpu_time`` (the same call's CPU
        seconds of this process, CasADi's ``t_proc_total``; 0 on a Newton re-solve),
        ``function_time`` (the part
        of it spent evaluating the NLP functions and derivatives; the rest is mostly the
        linear solver), ``regularized_iterations`` and ``max_regularization`` (iterations
        whose KKT matrix had the wrong inertia and the largest Hessian shift delta_w IPOPT
        added), ``max_violation`` (of all constraints), ``most_violated`` (group, step, row),
        ``verdict_time`` (wall seconds of the verdict when `dmoc.optimize` judged the
        optimum: the replay and the checks at the knots, `dmoc.drivers.verdict.judge`),
        ``light_verdict`` (the verdict of a warm re-solve, `dmoc.drivers.verdict.light_judge`)
        and ``verdict_compiled`` (its figures in one compiled evaluation,
        `dmoc.drivers.verdict_figures`), and with ``linear_solver_report=True`` ``linear_solver``
        (`dmoc.optimal_control.solver.linear_solver.linear_solver_report`).
    x : ndarray, shape (problem.x_layout.size,)
        The NLP vector in the system's units (IPOPT's iterate times ``problem.x_scale``);
        ``problem.x_layout.unpack(x, name)`` reads any block (e.g. the end impulse
        ``"nu"``); its block "q" holds q - q_ref (``problem.configurations(x)`` gives q).
    lam_x, lam_g : ndarray, shapes like x and like problem.g_layout
        IPOPT's multipliers of the bounds and of the constraints at `x`, converted to the
        unscaled NLP (``lam_x = lam_x_ipopt / x_scale``, ``lam_g = g_scale * lam_g_ipopt``).
        The entries of lam_x whose bounds are equal (the given boundary data) are made on
        first access, as IPOPT's ``fixed_variable_treatment`` "make_parameter" makes them
        (`dmoc.optimal_control.solver.fixed_multipliers`; a warm start from the result does not read them).
    structure : str
        The problem's `structure` key: a result warm-starts (primal and dual) any problem
        with the same key, e.g. one from ``problem.with_boundary(...)``.
    q_ref : ndarray, shape (n,)
        The problem's `q_ref`, on which `x` is centered.
    verdict : Verdict or None
        The figures of `dmoc.optimize`'s checks (`dmoc.Verdict`); None when the
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
        fields (so `Trajectory.load`, or `RotationTrajectory.load` of a result on the group,
        reads it too), x, the multipliers, cost, status,
        message, structure, stats and the verdict (as JSON)."""
        extra = {RESULT_PREFIX + k: np.asarray(getattr(self, k))
                 for k in ("cost", "success", "status", "message", "x", "lam_x", "lam_g", "structure",
                           "q_ref") if getattr(self, k) is not None}
        extra[RESULT_PREFIX + "stats"] = json.dumps(self.stats, default=str)
        if self.verdict is not None:
            extra[RESULT_PREFIX + "verdict"] = json.dumps(self.verdict.as_dict())
        write(self.trajectory, path, extra)

    @classmethod
    def load(cls, path):
        """Read a result written by `save`, exactly (its trajectory a RotationTrajectory
        when it was one); ``optimize(problem, guess=loaded)`` warm-starts as from the
        result itself (a problem of a vector space).

        Raises
        ------
        MissingFileError
            If there is no file at `path` (a FileNotFoundError).
        TrajectoryFileError
            If the file is not a trajectory file (`Trajectory.load`,
            `RotationTrajectory.load`), or is one without the result's fields (written by
            their `save`, not `OptimizationResult.save`).
        """
        # checks the path, that it is an .npz
        traj, extra = read((Trajectory, RotationTrajectory), path, RESULT_FILE)
        missing = sorted(_RESULT_FIELDS - set(extra))
        unknown = sorted(set(extra) - _RESULT_FIELDS - _OPTIONAL_FIELDS)
        if missing or unknown:
            raise TrajectoryFileError(
                f"{str(path)!r} is not {RESULT_FILE}: " + (
                    f"it lacks the fields {missing}" + ("; it is a trajectory file (read it "
                    f"with {type(traj).__name__}.load)." if len(missing) == len(_RESULT_FIELDS) else ".")
                    if missing else f"it holds result fields a result does not have: {unknown}."))
        return cls(traj, **_checked_fields(path, extra, traj.q.shape[1]))


def _checked_fields(path, extra, n):
    """The keyword arguments of OptimizationResult but the trajectory, from the result
    fields `extra` of the file at `path` (a trajectory of n coordinates), each checked
    against its type and shape; TrajectoryFileError naming the field otherwise."""
    def text(name):
        return str(scalar(path, RESULT_FILE, RESULT_PREFIX + name, extra[name], "U"))

    def vector(name, size=None):
        if name not in extra:           # x and the multipliers only when known
            return None
        value = extra[name]
        if value.dtype.kind not in "fiu" or value.ndim != 1 or size not in (None, value.size):
            shape = "(n,) = " + str((size,)) if size is not None else "(k,)"
            raise TrajectoryFileError(
                f"{str(path)!r} is not {RESULT_FILE}: `{RESULT_PREFIX}{name}` must be a real "
                f"vector of shape {shape}; got dtype {value.dtype}, shape {value.shape}.")
        return value.astype(float)

    x = vector("x")
    values = {"cost": float(scalar(path, RESULT_FILE, RESULT_PREFIX + "cost", extra["cost"], "fiu")),
              "success": bool(scalar(path, RESULT_FILE, RESULT_PREFIX + "success", extra["success"], "b")),
              "status": status_of(text("status")), "message": text("message"),
              "stats": _json(path, "stats", text("stats")),
              "x": x, "lam_x": vector("lam_x", None if x is None else x.size),
              "lam_g": vector("lam_g"), "structure": text("structure"),
              "q_ref": vector("q_ref", n)}     # files from before q_ref have none
    if "verdict" in extra:               # files of unjudged results have none
        values["verdict"] = _verdict(path, _json(path, "verdict", text("verdict")))
    return values


def _json(path, name, text):
    """The JSON object (dict) of field `name` (`text`)."""
    try:
        value = json.loads(text)
    except (ValueError, RecursionError) as err:
        value = err
    if not isinstance(value, dict):
        got = (f"{type(value).__name__}: {value}" if isinstance(value, Exception)
               else f"a JSON {type(value).__name__}")
        raise TrajectoryFileError(f"{str(path)!r} is not {RESULT_FILE}: `{RESULT_PREFIX}{name}` "
                                  f"must be a JSON object; got {got}.")
    return value


def _verdict(path, values):
    """The Verdict of the dict `values`, whose keys and value types are Verdict's."""
    try:
        return Verdict.checked(values)
    except InputError as err:
        raise TrajectoryFileError(f"{str(path)!r} is not {RESULT_FILE}: `{RESULT_PREFIX}verdict` "
                                  f"{err}.") from None


RESULT_FILE = "an optimization result file (one written by OptimizationResult.save)"
# the fields every `OptimizationResult.save` writes (x and the multipliers only when known)
_RESULT_FIELDS = {"cost", "success", "status", "message", "stats", "structure"}
_OPTIONAL_FIELDS = {"x", "lam_x", "lam_g", "q_ref", "verdict"}
