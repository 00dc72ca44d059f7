"""A feedback law closing the loop inside the Dirac integrator (consumer 1 of the step
residual): `simulate(..., feedback=...)` checked against the run it drives, and the
control of step k computed from the state the simulator reached, u_k = law(k, q_k, p_k),
before the step (37) is solved (the time-varying LQR gains of `dmoc.tvlqr` are one).
"""

import numpy as np

from .._util import checks
from ..errors import InputError
from ..principle.trajectory import Trajectory


def closed_loop(run, feedback, controls):
    """The controls array to fill and the law of a `Run` (`prepare`) driven by `feedback`.

    Parameters
    ----------
    run : Run
        The checked run, its variant "+" (the law reads p_k, which the (-) step changes).
    feedback : object
        A `dmoc.FeedbackGains`, or any object with ``trajectory`` (the Trajectory it is
        taken around: its horizon and h) and ``control(k, q, p)`` returning the controls
        of step k at the rule's control nodes, shape (disc.n_controls,).
    controls : None
        `simulate`'s `controls`: the law computes every step's controls, so none may be given.

    Returns
    -------
    controls : ndarray, shape (steps, disc.n_controls)
        Zeros, written step by step with what the law returns.
    law : callable
        (k, state) -> controls of step k, shape (disc.n_controls,), from the stepper's
        state row (its q and p blocks).
    """
    if controls is not None:
        raise InputError("`controls` and `feedback` exclude each other: with `feedback` the "
                         "controls of each step are feedback.control(k, q_k, p_k); pass one of them.")
    trajectory = getattr(feedback, "trajectory", None)
    if not callable(getattr(feedback, "control", None)) or not isinstance(trajectory, Trajectory):
        raise InputError(f"`feedback` must be FeedbackGains (`dmoc.tvlqr`), or an object with a "
                         f"`trajectory` and a method control(k, q, p); got {type(feedback).__name__}.")
    disc, steps = run.disc, run.controls.shape[0]
    if run.formulation.multiplier_node != 0:
        raise InputError(f"`feedback` needs variant '+' (the law reads p_k, which the (-) step "
                         f"corrects by the impulse of the step before); got variant "
                         f"{run.formulation.name!r}.")
    if steps > trajectory.steps:
        raise InputError(f"`steps` must be at most the horizon of `feedback`, "
                         f"{trajectory.steps} steps; got {steps}.")
    if not np.isclose(disc.h, trajectory.h, rtol=1e-12, atol=0):
        raise InputError(f"`disc` must have the step of `feedback`'s trajectory, h = "
                         f"{trajectory.h!r} (its law is indexed by step); got h = {disc.h!r}.")
    if trajectory.u.shape[1] != disc.n_controls or trajectory.q.shape[1] != disc.system.n:
        raise InputError(f"`feedback` must be taken around a trajectory of n = {disc.system.n} "
                         f"and {disc.n_controls} controls per step, as `disc`; got n = "
                         f"{trajectory.q.shape[1]} and {trajectory.u.shape[1]} controls per step.")
    q, p, n_c = run.stepper.state.slice("q"), run.stepper.state.slice("p"), disc.n_controls

    def law(k, state):
        return checks.array(f"feedback.control({k}, q, p)", feedback.control(k, state[q], state[p]), (n_c,))
    return np.zeros((steps, n_c)), law
