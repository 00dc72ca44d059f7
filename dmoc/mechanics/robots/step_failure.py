"""Why a step of a robot's simulation may have failed, for the mechanics stage: from the
last accepted state (q, p) and the step h, the joint velocities v = M(q)^-1 p, the fastest
time scales of the motion against h, and the conditioning of the mass matrix M(q) of
`RobotSystem` (L = 1/2 v^T M(q) v - V(q)) or of `FloatingBaseRobot`.
"""

import numpy as np

# h times a rate above which Newton's start from the previous step (an O(h |v|) guess of a
# rotation) is no longer close: the step is too large for the motion it must resolve
RATE_PER_STEP = 0.5
# a mass matrix whose condition number exceeds this is called near-singular: a joint
# with (almost) no inertia about its axis, whose velocity the torques can drive far up
NEAR_SINGULAR = 1e8


def step_failure_hint(system, q, p, h):
    """A sentence for a SolverError: the velocities at the last accepted state, the
    likely cause of a failed step and what to do.

    Parameters
    ----------
    system : RobotSystem
    q, p : ndarray, shape (n,)
        The last accepted configuration and momentum.
    h : float
        The step.

    Returns
    -------
    str

    Notes
    -----
    The rates compared with 1/h are the largest turning speed |v_i| (rad/s: the rotation of
    a step is h |v_i|; a revolute or continuous joint's or a wheeled base's heading, not a
    prismatic joint's or the base's x, y, in m/s, whose h |v_i| is no angle) and the largest
    frequency omega of the linearized free motion about q,
    omega^2 the largest |eigenvalue| of M(q)^-1 K(q) with K = d^2V/dq^2 the stiffness of
    gravity. Not the joints' friction rates (eigenvalues of M(q)^-1 D): viscous friction is
    linear in v and adds -D/2 to the step's Jacobian, the sign of its -M/h, so it never
    makes a step harder to solve (the arm6 model's damping on its light wrist, a rate of
    218/s, would have advised h <= 0.0011 where h = 0.01 converges).
    """
    M = np.array(system.mass_matrix(q))
    return explained(M, p, h, system.names, system.units["q"], np.array(system.stiffness(q)))


def explained(M, p, h, names, units, K=None):
    """The sentence of `step_failure_hint` from the mass matrix M (n, n) of the velocity
    v = M^-1 p, p (n,) the momentum, the step h, the velocity's `names` and the `units` of
    its coordinates (n,) and the stiffness of gravity K (n, n), None where gravity has none
    (a floating base: in a uniform field it falls as a whole). Every speed is given with its
    unit; only the turning speeds, those of coordinates in rad (joints and headings, not a
    base's translation nor a prismatic joint), are rates whose h |v_i| is an angle."""
    v = np.linalg.solve(M, p)
    inertia = np.linalg.eigvalsh(M)
    condition = inertia[-1] / inertia[0] if inertia[0] > 0 else np.inf
    omega = 0.0 if K is None else np.sqrt(np.abs(np.linalg.eigvals(np.linalg.solve(M, K))).max())
    turning = np.where([unit == "rad" for unit in units], np.abs(v), 0.0)
    speeds = ", ".join(f"{name} {x:.3g} {unit}/s" for name, x, unit in zip(names, v, units))
    state = (f"velocities at the last accepted step: {speeds}"
             + f"; M(q) has condition number {condition:.2g} (eigenvalues {inertia[0]:.2g} to "
             f"{inertia[-1]:.2g})" + ("" if K is None else f", the fastest gravity mode "
                                                           f"omega = {omega:.3g} rad/s"))
    rate = max(turning.max(initial=0.0), omega)
    if condition > NEAR_SINGULAR:
        cause = ("likely cause: near-singular inertia, a link with (almost) no inertia about "
                 "a joint axis, whose joint speeds up without bound; give the links realistic "
                 "inertias in the URDF (or lock that joint with `joints=`) and take a smaller h")
    elif h * rate > RATE_PER_STEP:
        cause = (f"likely cause: h = {h:.3g} is too large for the fastest motion (h times its "
                 f"rate {rate:.3g}/s is {h * rate:.2g}); take h <= {RATE_PER_STEP / 2 / rate:.2g}, "
                 f"or check the torques against `effort_limits` if they drive the motion")
    else:
        cause = ("neither a fast motion nor a near-singular M(q) explains it; check the "
                 "controls against `effort_limits` and try a smaller h")
    return f"{state}; {cause}"

