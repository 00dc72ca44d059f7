"""Consumer 2 of the group step residual, its statement: a DMOC problem for a rigid body on
SO(3) x R^n_x (Kobilarov & Marsden, "Discrete geometric optimal control on Lie groups",
IEEE T-RO 27 (2011)): minimize the discrete control effort sum_k h |u_k|^2 subject to the
`GroupStepResidual` at every step (its constraint rows included), from a rotation, a
position and a velocity to others. Its NLP is `dmoc.optimal_control.nlp.group_transcription`.
"""

import copy

import casadi as ca
import numpy as np

from ..._util import checks
from ..._util.symbolic import checked_function
from ...discrete.group_discretization import GroupDiscretization
from ...errors import InputError
from ...mechanics.rigid_body import check_allowed_velocity
from ...mechanics.rotations import as_rotation
from ...principle.group_residual import group_step_residual
from ..solver.ipopt import DEFAULT_IPOPT_OPTIONS
from .group_boundary import end_rows, free_goal_momentum, goal_coordinates
from .parameters import refuse_comparisons


class GroupOptimalControlProblem:
    """A rigid body steered on SO(3) x R^n_x: minimize sum_k h |u_k|^2 (the integral of
    |tau|^2 for controls held on each step) subject to the group step residual at every
    step.

    Parameters
    ----------
    disc : GroupDiscretization
        Of a RigidBody with controls (e.g. `dmoc.systems.spacecraft`, or
        `dmoc.systems.chaplygin_sphere(torques=True)`) or of a FloatingBaseRobot; its h
        fixes the duration steps * h.
    steps : int
        N.
    R_start, R_goal : array_like, shape (3, 3)
        The rotations at t = 0 and t = N h; `R_goal` None leaves the rotation at the goal
        free (no rotation rows: any orientation), as a whole (no entries of it alone).
    omega_start, omega_goal : array_like, shape (3,), optional
        Body angular velocities at the ends (default: at rest).
    x_start, x_goal : array_like, shape (n_x,), optional
        The vector coordinates at the ends, for a body with coordinates (required then).
        Entries of `x_goal` may be None: that coordinate is free at the goal (the NLP has
        no row for it), e.g. the base position of a free-floating robot, which its
        conserved momentum decides. A moving goal (velocity not zero) refuses free entries
        its mass matrix or constraint rows depend on.
    x_velocity_start, x_velocity_goal : array_like, shape (n_x,), optional
        Their velocities at the ends (default: at rest). The velocity (omega, x') at each
        end must satisfy the constraints there.
    path_constraints : callable, optional
        ``path_constraints(R, x, u) -> g``, imposed as g <= 0 at every knot q_0 ... q_N:
        R the rotation R_k (a 3 x 3 CasADi SX matrix), x the vector coordinates x_k
        (n_x,), u the control u_k of the step that starts at the knot (u_{N-1} at q_N),
        shape (n_u,); g any shape, its entries (column-major) the rows, expressions not
        comparisons (write |x_{1:2} - c| >= r as ``r**2 - sumsqr(x[:2] - c)``). Rows that
        read R and x alone must hold at the given ends (refused otherwise).

    Attributes
    ----------
    disc, steps, residual : GroupDiscretization, int, GroupStepResidual
    R_start, R_goal : numpy.ndarray, shape (3, 3)
        R_goal None when free.
    x_start, x_goal : numpy.ndarray, shape (n_x,)
        x_goal NaN where free.
    p_start, p_goal : numpy.ndarray, shape (3 + n_x,)
        The momenta M(q) (omega, x') the ends impose (M the body's `generalized_mass`,
        diag(J, M_x) for a RigidBody).
    end_rows : numpy.ndarray of int
        The rows of p_N = p_goal + A(q_N)^T nu the NLP imposes: all n, but for a body that
        has momenta the controls do not change (a FloatingBaseRobot's `momentum_map`) as
        many fewer, which p_0 fixes (`dmoc.optimal_control.statement.group_boundary.end_rows`).
    path_constraints : casadi.Function or None
        ``(R, x, u) -> g`` (`group_path_function`), None without path constraints.

    Notes
    -----
    The NLP carries, per knot, q_k (the 9 entries of R_k, then x_k) and p_k, per step the
    increment f_k (Cayley coordinates, then dx_k), the multipliers lam_k and the control
    u_k, and the end impulse nu (m); its rows per step are the 2n + m rows of the
    residual and the 9 + n_x rows q_{k+1} - (R_k cay(f_k), x_k + dx_k) (the residual's
    `reconstruction`), so every R_k is an exact group product of the start and the
    increments to the solver's tolerance. q_0 and p_0 are fixed by bounds; the goal is the
    3 rows cay^{-1}(R_goal^T R_N) = 0 (the 9 entries of R_N = R_goal would be 6 rows too
    many; none when R_goal is free) and x_N,i = x_goal,i for the given entries, and the end momentum the (+) form's
    p_N = p_goal + A(q_N)^T nu (an impulse nu at q_N, as `Formulation.momentum_conditions`
    on R^n), its `end_rows`. The path
    constraints are the rows g(R_k, x_k, u_k) <= 0, k = 0 ... N, as the knot rows of a
    problem on R^n (`dmoc.optimal_control.nlp.path_terms`); between knots nothing is
    imposed.
    """

    def __init__(self, disc, steps, *, R_start, R_goal, omega_start=(0.0, 0.0, 0.0),
                 omega_goal=(0.0, 0.0, 0.0), x_start=None, x_goal=None, x_velocity_start=None,
                 x_velocity_goal=None, path_constraints=None):
        checks.instance("disc", disc, GroupDiscretization, "a GroupDiscretization")
        if disc.n_controls == 0:
            raise InputError("`disc` must be of a RigidBody with controls (n_u > 0), e.g. "
                             "dmoc.systems.spacecraft(); this one has none.")
        self.disc, self.steps = disc, checks.positive_int("steps", steps)
        self.residual = group_step_residual(disc)
        body = disc.system
        self.R_start = as_rotation("R_start", R_start)
        self.R_goal = None if R_goal is None else as_rotation("R_goal", R_goal)
        self.x_start = _coordinates(body, x_start)
        self.x_goal = goal_coordinates(body, x_goal)
        ends = []
        for end, R, x, omega, rate in (("start", self.R_start, self.x_start, omega_start, x_velocity_start),
                                       ("goal", self.R_goal, self.x_goal, omega_goal, x_velocity_goal)):
            v = np.concatenate([checks.array(f"omega_{end}", omega, (3,)),
                                np.zeros(body.n_x) if rate is None
                                else checks.array(f"x_velocity_{end}", rate, (body.n_x,))])
            q = np.concatenate([np.full(9, np.nan) if R is None else R.ravel(), x])
            filled = np.where(np.isnan(q), np.concatenate([self.R_start.ravel(), self.x_start]), q)
            p = free_goal_momentum(body, q, v, filled)
            check_allowed_velocity(body, filled, v, f"`omega_{end}`, `x_velocity_{end}` at `R_{end}`, `x_{end}`")
            ends.append((q, p))
        (_, self.p_start), (_, self.p_goal) = ends
        self.end_rows = end_rows(body, *ends, self.duration)
        self.path_constraints = (None if path_constraints is None
                                 else group_path_function(path_constraints, disc))
        if self.path_constraints is not None:
            for end, R, x in (("start", self.R_start, self.x_start), ("goal", self.R_goal, self.x_goal)):
                _refuse_violated_end(self.path_constraints, end, R, x)

    @property
    def duration(self):
        """N h."""
        return self.steps * self.disc.h

    @property
    def free_time(self):
        """False: the final time N h is fixed (as `OptimalControlProblem.free_time`)."""
        return False

    def with_steps(self, steps):
        """This problem on N = `steps` steps over the same time, h = N_old h_old / N: the
        body discretized anew, the same ends, velocities and path constraints (the
        refinement of `dmoc.drivers.accuracy`, the coarse solve of
        `dmoc.drivers.error_estimate`)."""
        new = copy.copy(self)
        new.steps = checks.positive_int("steps", steps)
        new.disc = GroupDiscretization(self.disc.system, self.duration / new.steps, self.disc.rule)
        new.residual = group_step_residual(new.disc)
        return new

    def geodesic(self, shares=None):
        """The rotations R_start exp(s_k log(R_start^T R_goal)) along the shortest rotation
        between the ends, shape (N+1, 3, 3), at the `shares` s_k of the way (N+1,), default
        k/N: the default guess (R_start at every knot when the goal's rotation is free)."""
        phi = np.zeros(3) if self.R_goal is None else rotation_vector(self.R_start.T @ self.R_goal)
        shares = np.linspace(0.0, 1.0, self.steps + 1) if shares is None else shares
        return self.R_start @ rotation_matrix(np.outer(shares, phi))

    def __repr__(self):
        return f"GroupOptimalControlProblem({self.disc!r}, steps={self.steps})"


def _coordinates(body, x_start):
    """`x_start` as the body's vector coordinates (n_x,), required when it has them."""
    if body.n_x == 0 and x_start is None:
        return np.zeros(0)
    if x_start is None:
        raise InputError(f"`x_start` is required for {body!r}: its coordinates, shape "
                         f"({body.n_x},).")
    return checks.array("x_start", x_start, (body.n_x,))


def group_path_function(path, disc):
    """The user's path constraints path(R, x, u) on SO(3) x R^n_x, checked on symbols (R a
    3 x 3 SX, x (n_x,), u (n_u,) of `disc`), as the Function ``(R, x, u) -> g``, g
    flattened to a column and imposed as g <= 0; refused when it fails on symbols, returns
    no CasADi expression or returns comparisons (`refuse_comparisons`), as the path
    constraints of a problem on R^n (`dmoc.optimal_control.statement.parameters.path_function`)."""
    symbols = [ca.SX.sym("R", 3, 3), ca.SX.sym("x", disc.system.n_x), ca.SX.sym("u", disc.n_controls)]
    at_knot = checked_function("path_constraints", path, symbols, ("R", "x", "u"), None)
    refuse_comparisons(at_knot(*symbols))
    return at_knot


def _refuse_violated_end(path, end, R, x):
    """InputError when the given end (R, x) violates a row of `path` that reads the given
    R and entries of x alone (not u, nor R None or a free entry of x, NaN): every row holds
    at q_0 and q_N, so the problem would have no solution."""
    u, free, turn = ca.SX.sym("u", path.size1_in("u")), ca.SX.sym("x", x.size), ca.SX.sym("R", 3, 3)
    given = ca.DM(np.nan_to_num(x))
    g = path(turn if R is None else ca.DM(R), ca.if_else(ca.DM(np.isnan(x).astype(float)), free, given), u)
    unknown = ca.vertcat(u, free, ca.vec(turn))
    rows = [i for i in range(g.numel()) if not ca.depends_on(g[i], unknown)]
    values = [float(ca.evalf(g[i])) for i in rows]
    if values and max(values) > DEFAULT_IPOPT_OPTIONS["constr_viol_tol"]:
        worst = int(np.argmax(values))
        raise InputError(f"`R_{end}`, `x_{end}` must satisfy `path_constraints` g <= 0, which "
                         f"hold at every knot q_0 ... q_N, the ends included; got "
                         f"g[{rows[worst]}] = {values[worst]:.6g} there. Move the end or the "
                         f"constraint.")


def rotation_matrix(phi):
    """exp(phi^) by Rodrigues' formula, shape (3,) -> (3, 3), or a stack (..., 3) -> (...,
    3, 3) at once (the geodesic's knots)."""
    phi = np.asarray(phi, dtype=float)
    angle = np.sqrt(np.sum(phi * phi, axis=-1))[..., None, None]
    K = np.zeros(phi.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -phi[..., 2], phi[..., 1], -phi[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = phi[..., 2], -phi[..., 1], phi[..., 0]
    small = angle < 1e-12                    # exp(phi^) = I + phi^ to round-off
    turned = np.where(small, 1.0, angle)
    return (np.eye(3) + np.where(small, 1.0, np.sin(turned) / turned) * K
            + np.where(small, 0.0, (1 - np.cos(turned)) / turned ** 2) * (K @ K))


def rotation_vector(R):
    """log(R) as a vector (3,), the rotation angle in [0, pi) times the axis."""
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return 0.5 * axis if angle < 1e-12 else angle / (2 * np.sin(angle)) * axis
