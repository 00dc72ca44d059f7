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
from ...errors import TrajectoryFileError, status_of
from ...principle.trajectory import Trajectory
from ...principle.trajectory_file import RESULT_PREFIX, read, write
from .verdict_record import Verdict


@dataclass
class OptimizationResult:
    """Outcome of `dmoc.optimize` (and of the raw IPOPT `solve`).

    Attributes
    ----------
    trajectory : Trajectory
        The optimal trajectory, or the last iterate when not `success`. A solve whose x is
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
        multipliers), ``solve_time`` (wall seconds of the solver call), ``ipopt_time`` (of them
        the seconds in CasADi's IPOPT call itself, as CasADi records them: without the
        conversions of the inputs and outputs), ``function_time`` (the part
        of it spent evaluating the NLP functions and derivatives; the rest is mostly the
        linear solver), ``regularized_iterations`` and ``max_regularization`` (iterations
        whose KKT matrix had the wrong inertia and the largest Hessian shift delta_w IPOPT
        added), ``max_violation`` (of all constraints), ``most_violated`` (group, step, row),
        and with ``linear_solver_report=True`` ``linear_solver``
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
        fields (so `Trajectory.load` reads it too), x, the multipliers, cost, status,
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
                   status_of(str(extra["status"])), str(extra["message"]), json.loads(str(extra["stats"])),
                   extra.get("x"), extra.get("lam_x"), extra.get("lam_g"), str(extra["structure"]),
                   extra.get("q_ref"),        # files from before q_ref have none
                   None if verdict is None else Verdict.from_dict(json.loads(str(verdict))))


RESULT_FILE = "an optimization result file (one written by OptimizationResult.save)"
# the fields every `OptimizationResult.save` writes (x and the multipliers only when known)
_RESULT_FIELDS = {"cost", "success", "status", "message", "stats", "structure"}
