"""A step of the simulator found by continuation in the step size (`dmoc.simulation.stepper`):
when Newton's method finds no root of the step equations (37)/(41) from the previous step's
solution, the root is followed from a small step, where it is the one near zero, up to the
full step.

The unknowns y = (dq, nu, ds) of a step from (q_k, p_k) under u_k (increments, multipliers,
stage values less q_k) solve G(y; q_k, p_k, u_k, t h) = 0 for every fraction t of the step.
At t = 0 the root is y = 0 (no increment, no impulse), and the Jacobian dG/dy there is that
of the continuous equations' velocity, multiplier and stage unknowns (regular for a regular
Lagrangian and independent constraints), so by the implicit function theorem one branch
y(t) leaves y = 0 smoothly: the physical one, whose end velocity tends to the continuous
flow's as t h -> 0, y(t) = t h (v, F, ...) + O(t^2). The other roots of a large step
(issue 40: the Lobatto rules' spurious branches) are not connected to it for small t.
`continued_step` walks t from a small fraction to 1, each Newton iteration (the stepper's
line-search `robust` step) started from the secant through the last two roots found
(y = 0 at t = 0 among them: the first root found is scaled by t'/t; before it, t times
the previous step's root), halving the
increment of t where Newton fails and doubling it where it succeeds (natural-parameter
continuation; Allgower and Georg, "Introduction to Numerical Continuation Methods", SIAM
2003, ch. 1). A fold of the branch before t = 1 (the physical root ceases to exist at this
h) leaves the step without a root: then it fails as before.
"""

import numpy as np

# the smallest fraction of h the continuation starts from, and the largest number of
# Newton solves it spends on one step (each a line-search Newton of up to max_iter)
SMALLEST_FRACTION = 2.0 ** -12
MOST_SOLVES = 60


def continued_step(stepper, state, u, h):
    """The step of `stepper` from `state` under `u` at step `h`, its root followed in the
    fraction t of h from t -> 0 to t = 1 (module notes), or None when the continuation
    does not reach t = 1 (a fold, or more than MOST_SOLVES solves).

    Parameters
    ----------
    stepper : DiracStepper
        Its `robust` step ``(state, u, h) -> (next, out)`` and `accepted`.
    state : ndarray, shape (stepper.state.size,)
        q_k, p_k and the warm start (the previous step's unknowns): the first fraction t
        starts from t times the warm start.
    u : ndarray, shape (n_controls,)
    h : float

    Returns
    -------
    (next, out) or None
        The next state, shape (state.size,), and the step's outputs, shape
        (stepper.out.size,), of the root at t = 1, as the robust step gives them.
    """
    blocks = [stepper.state.slice(name) for name in stepper.unknowns.blocks]
    unknowns = slice(blocks[0].start, blocks[-1].stop)      # the warm start y: dq, nu, ds in a row
    roots, warm = [(0.0, np.zeros(stepper.unknowns.size))], state[unknowns]
    fraction = increment = 0.5
    seed = fraction * warm
    for _ in range(MOST_SOLVES):
        trial = state.copy()
        trial[unknowns] = seed
        following, out = (np.array(x).ravel() for x in stepper.robust(trial, u, fraction * h))
        if stepper.accepted(out[None, :])[0]:
            if fraction == 1.0:
                return following, out
            roots.append((fraction, following[unknowns]))
            increment = min(2 * increment, 1.0 - fraction)
        else:
            increment /= 2
            if increment < SMALLEST_FRACTION:
                return None
        fraction = min(roots[-1][0] + increment, 1.0)
        seed = fraction * warm if len(roots) == 1 else _secant(roots[-2:], fraction)
    return None


def _secant(last, fraction):
    """The root predicted at `fraction` by the line through the `last` two (fraction,
    root) pairs."""
    (t0, y0), (t1, y1) = last
    return y1 + (fraction - t1) / (t1 - t0) * (y1 - y0)
