"""A robot on a floating base from its URDF (`dmoc.FloatingBaseRobot`) against Pinocchio,
which reads the same file under a free-flyer root joint with its own parser and algorithms:
the mass matrix, the gravity, the bias C(s, nu) nu + G and the centre of mass equal
Pinocchio's to 1e-12 at random states (its velocity nu = (R^T p', Omega, s'), dmoc's step velocity (Omega, p',
s')); the discrete flow keeps the total linear and angular momentum, read off Pinocchio's
centroidal momentum, to round-off over many steps, joint torques and friction acting
(internal forces: discrete Noether); it converges at order 2 to DOP853 on Pinocchio's
forward dynamics M(s) nu' + C(s, nu) nu + G = tau, with the base's rotation integrated by the
matrix ODE R' = R Omega^ written here; its rotations stay orthogonal to round-off; and a
DMOC turns a free-floating satellite by its arm alone at zero momentum (the falling cat),
its controls turning Pinocchio's robot the same way."""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc.mechanics.robots import example_urdf

pytest.importorskip("adam.casadi", reason="the robots extra (adam-robotics[casadi]) is not "
                    "installed: pip install -e '.[test]'")
pin = pytest.importorskip("pinocchio", reason="Pinocchio (pin), the tests' oracle, is not "
                          "installed: pip install -e '.[test]'")

PATH = example_urdf("space_arm")
GRAVITY = 9.81


def free_flyer(gravity):
    """Pinocchio's model of the file under a free-flyer root joint, g along -z."""
    model = pin.buildModelFromUrdf(str(PATH), pin.JointModelFreeFlyer())
    model.gravity.linear[:] = [0.0, 0.0, -gravity]
    return model, model.createData()


def pin_configuration(R, x):
    """Pinocchio's q = (p, quaternion (x, y, z, w), s) of dmoc's (R, x = (p, s))."""
    return np.concatenate([x[:3], pin.Quaternion(R).coeffs(), x[3:]])


def to_pin(R, n):
    """P, shape (n, n): Pinocchio's nu = (R^T p', Omega, s') = P (Omega, p', s')."""
    P = np.zeros((n, n))
    P[:3, 3:6], P[3:6, :3], P[6:, 6:] = R.T, np.eye(3), np.eye(n - 6)
    return P


def random_configuration(rng, n_s):
    R = pin.Quaternion(*(rng.normal(size=4) / 2)).normalized().toRotationMatrix()
    return R, np.concatenate([rng.normal(size=3), rng.uniform(-2.5, 2.5, n_s)])


def close(ours, theirs):
    """Equal to 1e-12 relative to the size of Pinocchio's value (at least 1)."""
    ours, theirs = np.asarray(ours, float).reshape(np.shape(theirs)), np.asarray(theirs)
    return np.abs(ours - theirs).max() <= 1e-12 * max(1.0, np.abs(theirs).max())


def potential_gradient(robot):
    """dU along the variations (eta, dp, ds) of (R cay(eps eta), p + eps dp, s + eps ds) at
    eps = 0, a Function of (R, x), shape (n,)."""
    R, x, e = ca.SX.sym("R", 3, 3), ca.SX.sym("x", robot.n_x), ca.SX.sym("e", robot.n)
    varied = robot.potential(ca.mtimes(R, dmoc.mechanics.rotations.cayley(e[:3])), x + e[3:])
    return ca.Function("dU", [R, x], [ca.substitute(ca.gradient(varied, e), e, 0 * e)])


def velocity_bias(robot):
    """C(s, nu) nu, a Function of (s, nu), from T = 1/2 nu^T M(s) nu by the Kirchhoff
    (Boltzmann-Hamel) equations in the body twist (v_B, Omega) of the base: with mu = M nu,
    mu_v' + Omega x mu_v and mu_w' + Omega x mu_w + v_B x mu_v for the base, d/dt dT/ds' -
    dT/ds for the joints, the bias the terms without nu'."""
    s, nu = ca.SX.sym("s", robot.n_u), ca.SX.sym("nu", robot.n)
    mu = ca.mtimes(robot.mass_matrix(s), nu)
    T = 0.5 * ca.dot(nu, mu)
    v, w = nu[:3], nu[3:6]
    coadjoint = ca.vertcat(ca.cross(w, mu[:3]), ca.cross(w, mu[3:6]) + ca.cross(v, mu[:3]),
                           -ca.gradient(T, s))
    return ca.Function("b", [s, nu], [ca.jtimes(mu, s, nu[6:]) + coadjoint])


def test_mass_matrix_gravity_bias_and_center_of_mass_equal_pinocchio_free_flyer():
    robot = dmoc.FloatingBaseRobot(PATH)
    model, data = free_flyer(GRAVITY)
    dU, bias, rng = potential_gradient(robot), velocity_bias(robot), np.random.default_rng(3)
    assert robot.mass == pytest.approx(pin.computeTotalMass(model), abs=1e-12)
    for _ in range(30):
        R, x = random_configuration(rng, robot.n_u)
        q, q_pin = np.concatenate([R.ravel(), x]), pin_configuration(R, x)
        M = pin.crba(model, data, q_pin)
        M = np.triu(M) + np.triu(M, 1).T
        P = to_pin(R, robot.n)
        assert close(robot.mass_matrix(x[3:]), M)
        assert close(robot.generalized_mass(q), P.T @ M @ P)
        assert close(robot.potential(R, x), pin.computePotentialEnergy(model, data, q_pin))
        dU_q = np.array(dU(R, x)).ravel()
        G = np.concatenate([R.T @ dU_q[3:6], dU_q[:3], dU_q[6:]])     # in Pinocchio's nu
        assert close(G, pin.computeGeneralizedGravity(model, data, q_pin))
        assert close(robot.center_of_mass(q), pin.centerOfMass(model, data, q_pin))
        nu = rng.uniform(-2, 2, robot.n)
        assert close(np.array(bias(x[3:], nu)).ravel() + G, pin.nonLinearEffects(model, data, q_pin, nu))


def momentum_about_origin(model, data, R, x, p):
    """Pinocchio's total (linear, angular about the world's origin) momentum at the velocity
    of dmoc's momentum p = (Pi, p_p, p_s) (n,): nu = M^-1 (R^T p_p, Pi, p_s) in Pinocchio's
    convention, then its centroidal momentum moved from the centre of mass to the origin."""
    q_pin = pin_configuration(R, x)
    M = pin.crba(model, data, q_pin)
    nu = np.linalg.solve(np.triu(M) + np.triu(M, 1).T, np.concatenate([R.T @ p[3:6], p[:3], p[6:]]))
    h = pin.computeCentroidalMomentum(model, data, q_pin, nu)
    c = pin.centerOfMass(model, data, q_pin)
    return np.concatenate([h.linear, h.angular + np.cross(c, h.linear)])


def test_discrete_flow_keeps_total_momentum_as_pinocchio_reads_it():
    robot = dmoc.FloatingBaseRobot(PATH, friction=0.3, gravity=0.0)
    model, data = free_flyer(0.0)
    steps, rng = 300, np.random.default_rng(5)
    controls = np.sin(np.outer(np.arange(steps) * 0.05, [1.0, 1.7])) * [2.0, -1.5]
    x0 = np.array([0.3, -0.2, 0.1, 0.5, -1.0])
    result = dmoc.simulate(dmoc.discretize(robot, 0.02), q0=(np.eye(3), x0),
                           v0=rng.normal(size=robot.n), steps=steps, controls=controls)
    traj = result.trajectory
    momenta = np.array([momentum_about_origin(model, data, R, x, p)
                        for R, x, p in zip(traj.R, traj.x, traj.p)])
    scale = np.abs(momenta).max()
    assert scale > 1.0 and np.ptp(traj.x[:, 3:], axis=0).min() > 0.5    # it moves
    assert np.abs(momenta - momenta[0]).max() <= 1e-13 * scale
    kept = np.array([np.array(robot.momentum_map(np.concatenate([R.ravel(), x]), p)).ravel()
                     for R, x, p in zip(traj.R, traj.x, traj.p)])
    assert np.abs(kept - momenta).max() <= 1e-13 * scale            # the robot's own J is Pinocchio's
    assert traj.orthogonality_defect.max() <= 1e-14


def dop853_end(model, data, R0, x0, v0, controls, damping, h):
    """(R, x) at t = N h by DOP853 on Pinocchio's forward dynamics (aba), the joint torques
    u_k - D s' held on each step [k h, (k + 1) h], the base's rotation by R' = R Omega^ and
    its position by p' = R v_B."""
    n_s = x0.size - 3

    def rhs(t, y, u):
        R, p, s, nu = y[:9].reshape(3, 3), y[9:12], y[12:12 + n_s], y[12 + n_s:]
        tau = np.concatenate([np.zeros(6), u - damping * nu[6:]])
        a = pin.aba(model, data, pin_configuration(R, np.concatenate([p, s])), nu, tau)
        w = nu[3:6]
        hat = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([(R @ hat).ravel(), R @ nu[:3], nu[6:], a])

    y = np.concatenate([R0.ravel(), x0, to_pin(R0, 6 + n_s) @ v0])
    for u in controls:
        y = solve_ivp(rhs, (0.0, h), y, method="DOP853", rtol=1e-12, atol=1e-12, args=(u,)).y[:, -1]
    return y[:9].reshape(3, 3), y[9:9 + x0.size]


def test_converges_at_order_two_to_dop853_on_pinocchio_dynamics():
    damping, u, T = 0.4, np.array([1.5, -0.8]), 1.0
    robot = dmoc.FloatingBaseRobot(PATH, friction=damping)
    model, data = free_flyer(GRAVITY)
    R0 = pin.Quaternion(0.9, 0.2, -0.3, 0.1).normalized().toRotationMatrix()
    x0, v0 = np.array([0.1, 0.2, -0.3, 0.4, -0.6]), np.array([0.6, -0.4, 0.9, 0.2, -0.1, 0.3, 1.2, -1.5])
    R_ref, x_ref = dop853_end(model, data, R0, x0, v0, [u], damping, T)
    errors = []
    for steps in (10, 20, 40):
        traj = dmoc.simulate(dmoc.discretize(robot, T / steps), q0=(R0, x0), v0=v0, steps=steps,
                             controls=np.tile(u, (steps, 1))).trajectory
        errors.append(max(np.abs(traj.R[-1] - R_ref).max(), np.abs(traj.x[-1] - x_ref).max()))
        assert traj.orthogonality_defect.max() <= 1e-14
    slopes = np.diff(np.log(errors)) / np.diff(np.log([10, 20, 40]))
    assert np.all(np.abs(-slopes - 2.0) < 0.35), (errors, slopes)
    assert errors[-1] > 1e-9      # above round-off: the slope is the scheme's


def test_floating_base_robot_refuses_bad_data():
    with pytest.raises(ValueError, match="joints"):
        dmoc.FloatingBaseRobot(PATH, joints=["wrist"])
    with pytest.raises(ValueError, match="gravity"):
        dmoc.FloatingBaseRobot(PATH, gravity=np.nan)
    with pytest.raises(ValueError, match="friction"):
        dmoc.FloatingBaseRobot(PATH, friction=[0.1, -0.1])


@pytest.mark.parametrize("gravity, kept", [(0.0, 6), (GRAVITY, 4)])
def test_the_goal_leaves_out_the_momenta_the_start_fixes(gravity, kept):
    """The NLP's constraint Jacobian has full row rank at a point of the dynamics (a
    simulated flow; the linear momentum's rows are dependent at every point, the angular
    momentum's on the flow); with every end row imposed it would lack `kept` (6 momenta
    without gravity; with it the linear momentum, whose z falls at -m g, and the vertical
    angular momentum)."""
    from dmoc.optimal_control.nlp.group_transcription import group_transcription
    robot = dmoc.FloatingBaseRobot(PATH, gravity=gravity)
    steps, h, x0 = 8, 0.1, np.array([0.1, 0.2, 0.3, 0.4, -0.5])
    v0, u = np.array([0.3, -0.2, 0.5, 0.1, 0.2, -0.1, 0.4, 0.3]), np.tile([0.5, -0.4], (steps, 1))
    disc = dmoc.discretize(robot, h)
    traj = dmoc.simulate(disc, q0=(np.eye(3), x0), v0=v0, steps=steps, controls=u).trajectory
    q_N = np.concatenate([traj.R[-1].ravel(), traj.x[-1]])
    v_N = np.linalg.solve(np.array(robot.generalized_mass(q_N)), traj.p[-1])
    problem = dmoc.GroupOptimalControlProblem(
        disc, steps, R_start=np.eye(3), R_goal=traj.R[-1], x_start=x0, x_goal=traj.x[-1],
        omega_start=v0[:3], x_velocity_start=v0[3:], omega_goal=v_N[:3], x_velocity_goal=v_N[3:])
    assert problem.end_rows.size == robot.n - kept
    ranks = []
    for rows in (problem.end_rows, np.arange(robot.n)):
        problem.end_rows = rows
        T = group_transcription(problem)
        blocks = {"q": np.hstack([traj.R.reshape(-1, 9), traj.x]).T, "p": traj.p.T,
                  "f": traj.f.T,
                  "lam": np.zeros((0, steps)), "u": u.T, "nu": np.zeros(0)}
        point = np.concatenate([blocks[name].ravel(order="F") for name in T.x_layout.blocks])
        nlp = T.separable
        jacobian = ca.Function("J", [nlp.x, nlp.p], [ca.jacobian(nlp.g, nlp.x), nlp.g])
        J, g = (np.array(v) for v in jacobian(point, T.p))
        assert np.abs(g).max() < 1e-10                                # a point of the NLP's rows
        J = J[:, T.lbx != T.ubx]
        ranks.append((np.linalg.matrix_rank(J), J.shape[0]))
    assert ranks[0][0] == ranks[0][1] and ranks[1][0] == ranks[1][1] - kept, ranks


def test_a_goal_the_momentum_maps_cannot_reach_is_refused():
    robot = dmoc.FloatingBaseRobot(PATH, gravity=0.0)
    disc, ends = dmoc.discretize(robot, 0.2), {"R_start": np.eye(3), "R_goal": np.eye(3)}
    with pytest.raises(dmoc.InputError, match="whatever the controls.*no trajectory joins the ends"):
        dmoc.GroupOptimalControlProblem(disc, 3, **ends, x_start=np.zeros(5), x_goal=np.zeros(5),
                                        x_velocity_goal=[0.1, 0, 0, 0, 0])
    with pytest.raises(dmoc.InputError, match=r"`x_goal` entries \[3\] are free .* mass matrix"):
        dmoc.GroupOptimalControlProblem(disc, 3, **ends, x_start=np.zeros(5), x_goal=[0, 0, 0, None, 0],
                                        x_velocity_goal=[0, 0, 0, 0.1, 0])


def test_free_floating_arm_turns_its_base_at_zero_momentum():
    """The falling cat: a satellite in orbit (no gravity) turned by 0.15 rad about its z
    axis, rest to rest, by its arm alone, the joints back where they started and within the
    file's limits. The total momentum stays zero, so the goal is stated once: the base's
    position is free (the continuous flow keeps the centre of mass c_0 and would end at
    c_0 - R_goal c_0; the discrete flow keeps the momentum exactly and c only to O(h^2), so
    that goal would be 3 rows the dynamics nearly imply, singular values ~5e-5 of the
    Jacobian at N = 20) and the end rows of the base's 6 momenta, which p_0 = 0 and
    discrete Noether imply exactly, are not imposed (`end_rows`): with them IPOPT's
    multipliers were not unique (|lam| 1e3 .. 4e9 from guesses 1e-12 .. 1e-6 apart) and a change of
    round-off ended at an acceptable level on a poor point."""
    robot = dmoc.FloatingBaseRobot(PATH, gravity=0.0)
    steps, T = 20, 6.0
    R_goal = pin.exp3(np.array([0.0, 0.0, 0.15]))
    x_start = np.zeros(robot.n_x)
    c0 = np.array(robot.center_of_mass(np.concatenate([np.eye(3).ravel(), x_start]))).ravel()
    lower, upper = robot.position_limits
    problem = dmoc.GroupOptimalControlProblem(
        dmoc.discretize(robot, T / steps), steps, R_start=np.eye(3), R_goal=R_goal, x_start=x_start,
        x_goal=[None, None, None, 0.0, 0.0],
        path_constraints=lambda R, x, u: ca.vertcat(x[3:] - upper, lower - x[3:]))
    assert problem.end_rows.tolist() == [6, 7]             # the joints' momenta alone
    result = dmoc.optimize(problem)
    assert result.success and result.verdict.passed
    traj = result.trajectory
    assert np.abs(traj.R[-1] - R_goal).max() <= 1e-9 and np.abs(traj.x[-1, 3:]).max() <= 1e-9
    assert np.ptp(traj.x[:, 3:], axis=0).min() > 1.0                 # the arm swings
    model, data = free_flyer(0.0)
    momenta = np.array([momentum_about_origin(model, data, R, x, p)
                        for R, x, p in zip(traj.R, traj.x, traj.p)])
    assert np.abs(momenta).max() <= 1e-10                            # at rest at the end too
    # the centre of mass stays put to O(h^2) (measured 1.9e-4 m at h = 0.3 s)
    centers = np.array([np.array(robot.center_of_mass(np.concatenate([R.ravel(), x]))).ravel()
                        for R, x in zip(traj.R, traj.x)])
    assert np.abs(centers - c0).max() < 1e-3
    assert np.abs(traj.x[-1, :3] - (c0 - R_goal @ c0)).max() < 1e-3
    # the controls, held on each step, turn Pinocchio's robot to within O(h^2) of the goal
    R_end, x_end = dop853_end(model, data, np.eye(3), x_start, np.zeros(robot.n), traj.u, 0.0, T / steps)
    # measured: 0.021 rad from R_goal, joints 0.037 rad from the start (h = 0.3 s)
    assert np.linalg.norm(pin.log3(R_goal.T @ R_end)) < 0.03, R_end
    assert np.abs(x_end[3:]).max() < 0.05, x_end


def test_a_step_too_large_for_the_motion_is_explained():
    """A failed step on the floating base names the base's and the joints' velocities and
    the likely cause: h against the fastest turning speed (here the base's |Omega_3| = 9.2
    rad/s, not its 9.7 m/s along x, a translation), not a gravity mode (the robot falls as
    a whole); at the h it advises the same second of motion converges."""
    robot = dmoc.FloatingBaseRobot(PATH)
    start = dict(q0=(np.eye(3), np.array([0.1, 0.2, -0.3, 0.4, -0.6])),
                 v0=np.array([2.74, -4.6, -9.18, -9.67, 6.27, 8.26, 2.13, 4.59]))
    with pytest.raises(dmoc.SolverError) as failure:
        dmoc.simulate(dmoc.discretize(robot, 0.1), steps=10, **start)
    message = str(failure.value)
    assert "joint velocities" not in message           # the base's Omega and p' are no joint's
    assert ("velocities at the last accepted step: Omega_1 2.74 rad/s, Omega_2 -4.6 rad/s, "
            "Omega_3 -9.18 rad/s, x -9.67 m/s") in message and "elbow 4.59 rad/s" in message
    assert "likely cause: h = 0.1 is too large for the fastest motion (h times its rate 9.18/s" in message
    assert "gravity mode" not in message
    advised = float(message.split("take h <= ")[1].split(",")[0])
    assert dmoc.simulate(dmoc.discretize(robot, advised), steps=int(1 / advised), **start).success
