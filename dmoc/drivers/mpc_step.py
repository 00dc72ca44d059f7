"""The record of one step of a receding-horizon controller (`dmoc.MPC`, a driver: the
optimizer in a closed loop): the start it solved from and how the measurement was made
into it, the controls it applied, and its solve's status and times."""

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class MPCStep:
    """The record of one controller step (`MPC.log`).

    Attributes
    ----------
    q, p : ndarray, shape (n,)
        The start the solve used: the measurement, or its projection (`corrected`). On
        SO(3) x R^n_x q is the configuration (rows of R, then x), shape (9 + n_x,), and
        p = (Pi, p_x), shape (3 + n_x,).
    u : ndarray, shape (len(control_nodes) * n_u,), or None
        The controls applied over the step, at the rule's control nodes; None when the
        step raised.
    success : bool
        Whether this step's solve succeeded.
    status : str
        IPOPT's return status.
    iterations : int
    solve_time : float
        Seconds in IPOPT.
    step_time : float
        Wall seconds of the whole `MPC.step` (boundary data, warm start, solve).
    warm_start : bool
        Whether IPOPT started from the shifted previous optimum's x and multipliers.
    plan_age : int or None
        Which optimum `u` comes from: 0 this step's, k > 0 (after failed solves, with
        ``on_failure="shift"``) the plan of k steps before, at its step k; None when the
        step raised.
    h : float or None
        The step over which `u` is to be applied: the discretization's, or with a free
        final time the step of the plan `u` comes from (the plant is simulated over it);
        None when the step raised.
    measurement : str
        The controller's measurement policy ("project").
    corrected : tuple of str
        What the measurement violated and the policy corrected, among "state_bounds",
        "holonomic" (g(q) = 0), "rotation" (R off SO(3)) and "velocity" (A(q) v = 0);
        empty when it was used as is.
    q_measured : ndarray, shape (n,), or (9 + n_x,) on SO(3) x R^n_x
    v_measured, p_measured : ndarray, shape (n,), or None
        The measurement as given (of v and p, the one not given is None).
    q_correction, v_correction : float
        Euclidean norms of q - q_measured and of the velocity's correction (0 for a
        measured p), in the coordinates' units.
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
    plan_age: int
    h: float
    measurement: str
    corrected: tuple
    q_measured: np.ndarray
    v_measured: np.ndarray
    p_measured: np.ndarray
    q_correction: float
    v_correction: float
