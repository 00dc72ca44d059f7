"""The record of a verdict on an optimum (consumer 2, solver half): the figures that
`dmoc.optimize` measures on what IPOPT returns, held by `OptimizationResult.verdict` and
written with it. The checks themselves are made by the drivers
(`dmoc.drivers.verdict`), which may run `simulate`.
"""

from dataclasses import asdict, dataclass, fields


from ...errors import InputError, Status, status_of

# The statuses of a verdict, worst first: a result takes the first check that fails.
STATUSES = (Status.NOT_REPLAYABLE, Status.GOAL_MISSED, Status.PATH_VIOLATED, Status.UNDER_RESOLVED)
# the fields a file may lack: written before they were measured
OPTIONAL = {"discretization_error", "path_limit", "goal_error", "path_cut", "path_cut_step", "path_cut_limit"}


@dataclass(frozen=True)
class Verdict:
    """What an optimum was found to be, beyond IPOPT's convergence.

    Attributes
    ----------
    status : dmoc.Status
        ``"passed"``, or the worst check that failed, in the order of `STATUSES`:
        ``"not_replayable"`` (`simulate` from the optimum's initial state with its controls
        departs from it), ``"goal_missed"`` (on SO(3): the last knot is not at the goal,
        `dmoc.drivers.group_verdict`), ``"path_violated"`` (a path constraint or a velocity bound fails
        at a knot q_k, or the rule's interpolant exceeds a path constraint between the
        knots by more than `dmoc.drivers.interpolant_path.CUT_LIMIT` of its scale),
        ``"under_resolved"`` (a step velocity changes by a large part of its peak within
        one step).
    replay_q, replay_p : float
        max_k |q_k - q_opt,k| over the span of the optimum's configurations (the largest
        max_k q - min_k q over the coordinates) and max_k |p_k - p_opt,k| over max |p_opt|:
        the replay's relative departures (inf when `simulate` fails before step N). An
        optimum that does not move measures q by its size, and one at the origin (or at
        rest, for p) in the system's units.
    replay_step : int
        The first step k whose replayed q_k or p_k departs beyond the threshold; -1 if none.
    velocity_jump : float
        The largest |v_{k+1/2} - v_{k-1/2}| / max_j |v_{j+1/2}| over knots and coordinates
        (`dmoc.diagnostics.velocity_changes`).
    jump_step : int
        The knot k where it is found.
    jump_coordinate : str
        The coordinate's name.
    path_violation : float
        The largest value g at the knots of a path-constraint row or a velocity bound row
        (lower - v, v - upper) relative to the row's scale (max(1, max_k |g_k|) of that
        row); 0 without path constraints and velocity bounds.
    path_step : int
        The knot k where it is found; -1 if none.
    path_row : int
        The row of `path_constraints` where it is found; -1 if none or if it is a velocity
        bound.
    path_limit : str
        The limit found violated, by name: ``"path_constraints row 2"`` or
        ``"velocity_bounds upper of delta (v[3] <= 0.4)"``; "" if none (and in files
        written before velocity bounds).
    path_cut : float
        The largest value of a path-constraint row on the rule's interpolant between the
        knots (`Trajectory.sample` at `dmoc.drivers.interpolant_path.BETWEEN_KNOTS` of every
        step) relative to the row's scale (max(1, max |g|) of that row at the knots and
        those points); 0 without path constraints or where the interpolant keeps every
        row (and in files written before it was measured).
    path_cut_step : int
        The step k (between knots k and k + 1) where it is found; -1 if none.
    path_cut_limit : str
        The row's name (as `path_limit`) where `path_cut` exceeds the limit, else "".
    discretization_error : float or None
        The estimated distance of the optimum from the continuous one. This is where the
        estimate of ``dmoc.drivers.error_estimate.estimate_error`` joins the verdict; None:
        not estimated.
    goal_error : float
        On SO(3) (`dmoc.drivers.group_verdict`): the larger of the angle in radians of
        R_goal^T R_N and max_i |x_N,i - x_goal,i| over the span of x; 0 on R^n, whose end
        conditions are the NLP's rows alone (and in files written before).
    """

    status: str
    replay_q: float
    replay_p: float
    replay_step: int
    velocity_jump: float
    jump_step: int
    jump_coordinate: str
    path_violation: float
    path_step: int
    path_row: int
    discretization_error: float = None
    path_limit: str = ""
    goal_error: float = 0.0
    path_cut: float = 0.0
    path_cut_step: int = -1
    path_cut_limit: str = ""

    @property
    def passed(self):
        """True when every check holds."""
        return self.status == Status.PASSED

    def as_dict(self):
        """The fields as a dict of plain values (JSON-safe but for inf; the status a `Status`,
        which `json.dumps` writes as its string)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, values):
        """The Verdict of `as_dict` (its status a `Status` again)."""
        return cls(**dict(values, status=status_of(values["status"])))

    @classmethod
    def checked(cls, values):
        """The Verdict of the dict `values` read from a file: its keys exactly the fields
        (those of `OPTIONAL` may be left out), each value of the
        field's type; else InputError saying which ("must ..." follows the caller's name of the dict)."""
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(values) - set(names))
        missing = sorted(set(names) - set(values) - OPTIONAL)
        if unknown or missing:
            raise InputError(f"must have the keys {names}; " + (
                f"got the unknown keys {unknown}" if unknown else f"it lacks {missing}"))
        for name, value in values.items():
            if not (isinstance(value, _TYPES[name]) and not isinstance(value, bool)
                    or value is None and name == "discretization_error"):
                raise InputError(f"must have {name!r} {_DESCRIBED[_TYPES[name]]}; got {value!r}")
        known = [status.value for status in (Status.PASSED, *STATUSES)]
        if values["status"] not in known:
            raise InputError(f"must have 'status' one of {known}; got {values['status']!r}")
        return cls.from_dict(values)


# the type of each field's value in a file (an int is a number too)
_TYPES = {"status": str, "replay_q": (int, float), "replay_p": (int, float), "replay_step": int,
          "velocity_jump": (int, float), "jump_step": int, "jump_coordinate": str,
          "path_violation": (int, float), "path_step": int, "path_row": int,
          "discretization_error": (int, float), "path_limit": str,
          "goal_error": (int, float), "path_cut": (int, float), "path_cut_step": int,
          "path_cut_limit": str}
_DESCRIBED = {str: "a string", int: "an integer", (int, float): "a number"}
