"""Model predictive control on the DMOC NLP (consumer 2, the optimizer in a closed loop): a
receding-horizon controller re-solves one problem structure from each measured state, its
start given by a momentum (`OptimalControlProblem(p_start=...)`), with IPOPT's kept solver
warm-started from the previous optimum shifted by one step, primal and dual, and applies
the first step's controls.
"""

import dataclasses
import time

import numpy as np

from .._util import checks
from ..errors import InputError
from .problem import OptimalControlProblem
from .solve import solve        # the raw IPOPT solve of one problem


@dataclasses.dataclass(frozen=True)
class MPCStep:
    """The record of one controller step (`MPC.log`).

    Attributes
    ----------
    q, p : ndarray, shape (n,)
        The measured start.
    u : ndarray, shape (len(control_nodes) * n_u,)
        The controls applied over the step, at the rule's control nodes.
    success : bool
    status : str
        IPOPT's return status.
    iterations : int
    solve_time : float
        Seconds in IPOPT.
    step_time : float
        Wall seconds of the whole `MPC.step` (boundary data, warm start, solve).
    warm_start : bool
        Whether IPOPT started from the shifted previous optimum's x and multipliers.
    """

    q: np.ndarray
    p: np.ndarray
    u: np.ndarray
    success: bool
    status: str
    iterations: int
    solve_time: float
    step_time: float
    warm_start: bool


class MPC:
    """A receding-horizon controller: at each measured state (q, v) or (q, p), the optimum
    of `problem` from there over its N steps; the first step's controls are applied.

    Parameters
    ----------
    problem : OptimalControlProblem
        The horizon (N steps of h), goal, costs and bounds; its start data are replaced by
        each measurement (as a start momentum: the problem is restated once with
        ``with_boundary(p_start=...)``, so every step solves the same NLP structure).
    guess : Trajectory or OptimizationResult, optional
        The first solve's guess (`optimize`); later solves start from the previous
        optimum shifted by one step.
    options : dict, optional
        IPOPT options (`optimize`).

    Attributes
    ----------
    problem : OptimalControlProblem
        The problem of the last step (its start the last measurement).
    plan : OptimizationResult or None
        The last step's optimum over the horizon.
    log : list of MPCStep
        One record per step.

    Notes
    -----
    The warm start is the previous optimum moved one step on: every block of x, of its
    bound multipliers and of the constraint multipliers indexed by step (q_k, p_k, lam_k,
    s_k, u_k and the dynamics and path rows of step k) takes the value of step k + 1, the
    last step's repeated; the boundary blocks keep theirs. IPOPT starts from it with
    ``warm_start_init_point`` (x clipped into the new bounds: q_0 is the measurement).

    Examples
    --------
    >>> import dmoc
    >>> controller = MPC(dmoc.problems.knife_edge_parking(20))
    >>> u = controller.step([0.0, 0.0, 0.0], v=[0.0, 0.0, 0.0])
    >>> u.shape, controller.log[-1].success
    ((2,), True)
    """

    def __init__(self, problem, *, guess=None, options=None):
        checks.instance("problem", problem, OptimalControlProblem, "an OptimalControlProblem")
        if not np.isfinite(problem.q_start).all():
            raise InputError("`problem` must have a fully given `q_start`: the controller's "
                             "measurements replace it, and the NLP keeps its structure.")
        n = problem.disc.system.n
        start = problem.p_start if problem.p_start is not None else np.zeros(n)
        self.problem = problem.with_boundary(p_start=start)
        self.plan, self.log = None, []
        self._guess, self._options = guess, options

    def step(self, q, *, v=None, p=None):
        """Solve from the measured state and return the controls of the first step.

        Parameters
        ----------
        q : array_like, shape (n,)
        v, p : array_like, shape (n,)
            The measured velocity (then p = dL/dv(q, v)) or momentum: exactly one.

        Returns
        -------
        ndarray, shape (len(control_nodes) * n_u,)
            The first step's controls at the rule's control nodes (node by node), to apply
            over one step h (``simulate(..., controls=u[None])``).
        """
        tic = time.perf_counter()
        system = self.problem.disc.system
        q = checks.array("q", q, (system.n,))
        if (v is None) == (p is None):
            raise InputError("give the measured state as `v` or as `p`, exactly one.")
        p = (np.array(system.momentum(q, checks.array("v", v, (system.n,)))).ravel() if p is None
             else checks.array("p", p, (system.n,)))
        self.problem = self.problem.with_boundary(q_start=q, p_start=p)
        guess = self._guess if self.plan is None else shifted(self.plan, self.problem)
        result = solve(self.problem, guess=guess, options=self._options, throw=False)
        u = result.trajectory.u[0].copy()
        self.plan = result
        self.log.append(MPCStep(q, p, u, result.success, result.status, result.stats["iterations"],
                                result.stats["solve_time"], time.perf_counter() - tic,
                                result.stats["warm_start"]))
        return u


def shifted(result, problem):
    """`result` (an optimum of `problem`'s structure) moved one step on: the blocks of x,
    lam_x and lam_g indexed by step take the next step's values, the last repeated."""
    T, N = problem.transcription, problem.steps
    return dataclasses.replace(result, x=_shifted(result.x, T.x_layout, N),
                               lam_x=_shifted(result.lam_x, T.x_layout, N),
                               lam_g=_shifted(result.lam_g, T.g_layout, N))


def _shifted(vector, layout, steps):
    """`vector` with each block of N or N + 1 columns (one per step or knot; N > 1) moved
    one column to the left, its last column kept."""
    out = np.array(vector, dtype=float)
    for offset, rows, cols in layout.blocks.values():
        if cols > 1 and cols in (steps, steps + 1):
            block = out[offset:offset + rows * cols].reshape(cols, rows)     # column-major
            block[:-1] = block[1:].copy()
    return out

