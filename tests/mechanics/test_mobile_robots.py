"""A mobile manipulator from its URDF (`dmoc.RobotSystem(path, wheels=...)`): the shipped
differential-drive base carrying a three-joint arm against Pinocchio, which reads the same
file with its own parser and algorithms, its base's pose (x, y, theta) a root joint of
prismatic x, prismatic y and revolute z (the same free coordinates as dmoc's); the rolling
rows against the wheels' kinematics written in this file from the file's numbers; the
simulated motion against DOP853 on M q'' = tau - b + A^T lam, A q' = 0 with Pinocchio's M
and b; a parking-and-reaching DMOC checked with Pinocchio's forward kinematics."""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

import dmoc
from dmoc.mechanics.robots import example_urdf

pytest.importorskip("adam.casadi", reason="the robots extra (adam-robotics[casadi]) is not "
                    "installed: pip install -e '.[test]'")
pin = pytest.importorskip("pinocchio", reason="Pinocchio (pin), the tests' oracle, is not "
                          "installed: pip install -e '.[test]'")

GRAVITY = 9.81
PATH = example_urdf("mobile_arm")
WHEELS = ("left_wheel", "right_wheel")
# the file's wheel geometry: radius, half the track, the axle's x in the base's frame
RADIUS, HALF_TRACK, AXLE_X = 0.08, 0.2, -0.1


@pytest.fixture(scope="module")
def robot():
    return dmoc.RobotSystem(PATH, wheels=WHEELS)


@pytest.fixture(scope="module")
def oracle(robot):
    """Pinocchio's model of the file on the root joint PX-PY-RZ, and conversions of our
    (q, v) to its (q, v): its continuous joints take (cos, sin), its joints another order."""
    root = pin.JointModelComposite()
    for joint in (pin.JointModelPX(), pin.JointModelPY(), pin.JointModelRZ()):
        root.addJoint(joint)
    model = pin.buildModelFromUrdf(str(PATH), root)
    model.gravity.linear[:] = [0.0, 0.0, -GRAVITY]
    order = [0, 1, 2] + [robot.names.index(name) for name in model.names[2:]]   # theirs -> ours

    def configuration(q):
        parts = [q[:3]]
        for joint, name in zip(model.joints[2:], model.names[2:]):
            x = q[robot.names.index(name)]
            parts.append([np.cos(x), np.sin(x)] if joint.nq == 2 else [x])
        return np.concatenate(parts)

    return model, model.createData(), order, configuration


def rolling_matrix(q):
    """A(q) of the base by hand, (3, 8), q = (x, y, theta, phi_l, phi_r, arm): each wheel's
    centre, at (AXLE_X, +-HALF_TRACK) in the base's frame, moves along the heading at
    r phidot (the left one at sigma - HALF_TRACK thetadot), and the axle does not slip
    sideways, -sin ydot ... with its offset: -s xdot + c ydot + AXLE_X thetadot = 0."""
    s, c = np.sin(q[2]), np.cos(q[2])
    return np.array([[c, s, -HALF_TRACK, -RADIUS, 0, 0, 0, 0],
                     [c, s, HALF_TRACK, 0, -RADIUS, 0, 0, 0],
                     [-s, c, AXLE_X, 0, 0, 0, 0, 0]])


def rolling_matrix_rate(q, v):
    """(dA/dt) v = thetadot (dA/dtheta) v, shape (3,)."""
    s, c = np.sin(q[2]), np.cos(q[2])
    return v[2] * np.array([-s * v[0] + c * v[1], -s * v[0] + c * v[1], -c * v[0] - s * v[1]])


def lagrangian_terms(system):
    """(M, G, bias C v + G, f(q, v, 0)) from the system's own L and f by differentiation."""
    q, v = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n)
    L = system.lagrangian(q, v)
    dL_dv, dL_dq = ca.gradient(L, v), ca.gradient(L, q)
    G = -ca.substitute(dL_dq, v, ca.SX.zeros(system.n))
    return (ca.Function("M", [q], [ca.hessian(L, v)[0]]), ca.Function("G", [q], [G]),
            ca.Function("b", [q, v], [ca.jtimes(dL_dv, q, v) - dL_dq]),
            ca.Function("f", [q, v], [system.force(q, v, ca.SX.zeros(system.n_u))]))


def close(ours, theirs):
    ours, theirs = np.asarray(ours, float).reshape(np.shape(theirs)), np.asarray(theirs)
    return np.abs(ours - theirs).max() <= 1e-12 * max(1.0, np.abs(theirs).max())


def test_mass_matrix_gravity_bias_and_constraints_equal_the_oracles(robot, oracle):
    model, data, order, configuration = oracle
    M, G, bias, force = lagrangian_terms(robot)
    tool = robot.link_position("tool")
    damping = np.array([0.0] * 3 + [0.02] * 2 + [0.05] * 3)     # the file's <dynamics>
    rng = np.random.default_rng(17)
    for _ in range(30):
        q, v = rng.uniform(-np.pi, np.pi, 8), rng.uniform(-3, 3, 8)
        q_pin, v_pin = configuration(q), v[order]
        theirs = pin.crba(model, data, q_pin)
        theirs = np.triu(theirs) + np.triu(theirs, 1).T
        assert close(np.array(M(q))[np.ix_(order, order)], theirs)
        assert close(np.array(robot.mass_matrix(q))[np.ix_(order, order)], theirs)
        assert close(np.array(G(q)).ravel()[order],
                     pin.computeGeneralizedGravity(model, data, q_pin))
        assert close(np.array(bias(q, v)).ravel()[order],
                     pin.nonLinearEffects(model, data, q_pin, v_pin))
        assert close(force(q, v), -damping * v)
        pin.framesForwardKinematics(model, data, q_pin)
        assert close(tool(q), data.oMf[model.getFrameId("tool")].translation)
        assert close(robot.constraint_matrix(q), rolling_matrix(q))


def test_the_wheels_names_limits_and_sizes_are_the_files(robot):
    assert (robot.n, robot.m, robot.n_u) == (8, 3, 5)
    assert robot.names == ("x", "y", "theta", "left_wheel", "right_wheel", "arm_yaw",
                           "arm_shoulder", "arm_elbow")
    assert robot.wheel_rows == ("left_wheel rolls", "right_wheel rolls",
                                "left_wheel does not slip sideways")
    assert [(w.joint, w.radius) for w in robot.wheels] == [("left_wheel", 0.08),
                                                           ("right_wheel", 0.08)]
    np.testing.assert_array_equal(robot.wheels[1].centre, [AXLE_X, -HALF_TRACK, 0.0])
    np.testing.assert_array_equal(robot.position_limits[1], [np.inf] * 5 + [2.9, 2.0, 2.5])
    np.testing.assert_array_equal(robot.effort_limits[1], [10, 10, 20, 30, 15])
    assert robot.units["q"] == ("m", "m", "rad") + ("rad",) * 5
    assert robot.control_names[0] == "tau_left_wheel"


# ---------------------------------------------------------------------------------------
# Simulation against DOP853 on the constrained equations

START_Q = np.array([0.3, -0.2, 0.4, 0.0, 0.0, 0.2, 0.5, -0.8])
TORQUES = np.array([0.8, 0.3, 0.5, 2.0, 1.0])       # wheels l, r; arm yaw, shoulder, elbow


def start_velocity(rate_l=3.0, rate_r=5.0):
    """A velocity in ker A(q0): the base driven by the wheel rates, the arm moving."""
    theta = START_Q[2]
    sigma, turn = RADIUS * (rate_l + rate_r) / 2, RADIUS * (rate_r - rate_l) / (2 * HALF_TRACK)
    lateral = -AXLE_X * turn                        # the base's origin ahead of the axle
    return np.array([sigma * np.cos(theta) - lateral * np.sin(theta),
                     sigma * np.sin(theta) + lateral * np.cos(theta), turn, rate_l, rate_r,
                     0.5, -0.3, 0.8])


def reference(oracle, q0, v0, T):
    """q(T) by DOP853 on [M -A^T; A 0] (q'', lam) = (tau - D v - b, -A' v), M and b
    Pinocchio's, A `rolling_matrix`."""
    model, data, order, configuration = oracle
    back = np.argsort(order)                        # ours -> theirs, as an index into theirs
    tau = np.concatenate([np.zeros(3), TORQUES])       # on our coordinates
    damping = np.array([0.0] * 3 + [0.02] * 2 + [0.05] * 3)

    def rhs(t, y):
        q, v = y[:8], y[8:]
        q_pin, v_pin = configuration(q), v[order]
        M = pin.crba(model, data, q_pin)
        M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(back, back)]
        b = pin.nonLinearEffects(model, data, q_pin, v_pin)[back]
        A = rolling_matrix(q)
        K = np.block([[M, -A.T], [A, np.zeros((3, 3))]])
        rest = np.concatenate([tau - damping * v - b, -rolling_matrix_rate(q, v)])
        return np.concatenate([v, np.linalg.solve(K, rest)[:8]])

    y = solve_ivp(rhs, (0, T), np.concatenate([q0, v0]), method="DOP853", rtol=1e-13, atol=1e-12).y
    return y[:8, -1]


def test_converges_to_dop853_at_the_midpoint_order_keeping_the_wheels_rolling(robot, oracle):
    """Errors at T = 0.5 s for N = 20, 40, 80: slope 2 within 0.35; along each run the
    discrete constraint (28) A((q_k + q_{k+1})/2) (q_{k+1} - q_k)/h = 0, with A written in
    this file, holds to round-off."""
    q0, v0, T = START_Q, start_velocity(), 0.5
    q_ref = reference(oracle, q0, v0, T)
    errors = []
    for N in (20, 40, 80):
        h = T / N
        q = dmoc.simulate(dmoc.discretize(robot, h), q0=q0, v0=v0, steps=N,
                          controls=np.tile(TORQUES, (N, 1))).trajectory.q
        errors.append(np.abs(q[-1] - q_ref).max())
        defects = [rolling_matrix((a + b) / 2) @ (b - a) / h for a, b in zip(q[:-1], q[1:])]
        assert np.abs(defects).max() < 1e-12 * (1 + np.abs(q).max()), np.abs(defects).max()
    slope = -np.polyfit(np.log([20, 40, 80]), np.log(errors), 1)[0]
    assert abs(slope - 2) < 0.35, (errors, slope)
    assert errors[-1] < 0.01 * np.abs(q_ref - q0).max(), errors


# ---------------------------------------------------------------------------------------
# Optimal control: park the base and reach a point with the tool

PARKED = np.array([0.8, 0.3, 0.5])                 # the base's goal pose (x, y, theta)
TARGET = np.array([1.1, 0.55, 0.45])               # the tool's goal in the world (m)


def reaching_arm(oracle):
    """The arm's angles that put the tool at TARGET with the base PARKED, by least squares
    on Pinocchio's forward kinematics (an elbow-up branch, within the limits)."""
    model, data, _, configuration = oracle

    def miss(arm):
        q = np.concatenate([PARKED, [0.0, 0.0], arm])
        pin.framesForwardKinematics(model, data, configuration(q))
        return data.oMf[model.getFrameId("tool")].translation - TARGET

    solution = least_squares(miss, [0.0, 0.5, 1.0], xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert np.abs(miss(solution.x)).max() < 1e-12
    return solution.x, miss


def test_parked_with_the_tool_at_a_target_the_wheels_roll(robot, oracle):
    """Rest to rest in 2 s (N = 20, midpoint): from the origin, arm folded, to the base
    PARKED with the arm's angles that reach TARGET and the wheel angles free: verdict
    passed, the tool at TARGET by Pinocchio to 1e-9, the wheels' rows (28) to round-off.
    The cost u^T u + 0.1 v^T v: the wheels turn 12.5 times as fast (rad/s) as the base
    drives (m/s), so a heavier price on v (1 or 10) buys an impulsive start in which the
    light turret's velocity swings faster than 20 steps resolve (verdict "under_resolved",
    measured)."""
    arm, miss = reaching_arm(oracle)
    q_start = np.array([0, 0, 0, 0, 0, 0, 0.3, 1.2])
    q_goal = [*PARKED, None, None, *arm]
    N, h = 20, 0.1
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(robot, h), N, q_start=q_start, q_goal=q_goal,
        control_bounds=robot.effort_limits, state_bounds=robot.position_limits,
        running_cost=lambda q, v, u: ca.sumsqr(u) + 0.1 * ca.sumsqr(v))
    result = dmoc.optimize(problem)
    assert result.success and result.verdict.status == "passed", result.verdict
    q = result.trajectory.q
    assert np.abs(miss(q[-1, 5:])).max() < 1e-9
    np.testing.assert_allclose(q[-1, :3], PARKED, atol=1e-9)
    defects = [rolling_matrix((a + b) / 2) @ (b - a) / h for a, b in zip(q[:-1], q[1:])]
    assert np.abs(defects).max() < 1e-12 * (1 + np.abs(q).max())
    assert np.abs(q[-1, 3:5]).min() > 1.0            # the wheels turned to get there


def test_a_failed_step_reads_the_base_and_the_joints(robot):
    q = START_Q
    hint = robot.step_failure_hint(q, np.array(robot.mass_matrix(q)) @ start_velocity(), 0.05)
    assert hint.startswith("velocities at the last accepted step: x ")     # x is no joint
    assert "arm_elbow 0.8" in hint


def test_a_step_too_large_is_explained_in_the_units_of_each_speed(robot):
    """At h = 0.2 the first step fails from wheel rates 20 and 30 rad/s: the hint gives the
    base's x, y speeds in m/s and its heading's and the joints' in rad/s (at step 0 the last
    accepted state is the start, whose velocity the wheel geometry gives), and it compares
    h with the fastest turning speed, the right wheel's 30 rad/s, never with a speed in m/s;
    at the h it advises the same second of motion converges."""
    v0 = start_velocity(20.0, 30.0)
    v0[5:] = (2.0, -3.0, 4.0)
    start = dict(q0=START_Q, v0=v0)
    with pytest.raises(dmoc.SolverError) as failure:
        dmoc.simulate(dmoc.discretize(robot, 0.2), steps=5, **start)
    message = str(failure.value)
    speeds = ", ".join(f"{name} {x:.3g} {unit}/s" for name, x, unit in zip(
        ("x", "y", "theta", "left_wheel", "right_wheel", "arm_yaw", "arm_shoulder", "arm_elbow"),
        v0, ("m", "m") + ("rad",) * 6))
    assert f"; velocities at the last accepted step: {speeds};" in message, message
    assert "h = 0.2 is too large for the fastest motion (h times its rate 30/s" in message, message
    advised = float(message.split("take h <= ")[1].split(",")[0])
    assert dmoc.simulate(dmoc.discretize(robot, advised), steps=int(np.ceil(1 / advised)), **start).success


def test_the_base_driving_faster_than_anything_turns_is_not_a_rate():
    """Wheels declared 2 m in radius, turning at 6 rad/s, drive the base straight at 12 m/s
    (v in ker A, checked): 12 m/s is the largest speed but no rate (h times it is no angle);
    the hint compares h with a turning speed or the gravity mode, at least the wheels'
    6 rad/s."""
    robot = dmoc.RobotSystem(PATH, wheels={"left_wheel": 2.0, "right_wheel": 2.0})
    q = np.array([0.3, -0.2, 0.0, 0.0, 0.0, 0.2, 0.5, -0.8])
    v = np.array([12.0, 0.0, 0.0, 6.0, 6.0, 0.0, 0.0, 0.0])
    assert np.abs(np.array(robot.constraint_matrix(q)) @ v).max() < 1e-12
    hint = robot.step_failure_hint(q, np.array(robot.mass_matrix(q)) @ v, 0.2)
    assert hint.startswith("velocities at the last accepted step: x 12 m/s, "), hint
    rate = float(hint.split("h times its rate ")[1].split("/s")[0])
    assert 6.0 <= rate < 12.0, hint


# ---------------------------------------------------------------------------------------
# What the convention does not cover, refused with the reason

def edited(tmp_path, *replacements):
    """The shipped file with `replacements` (old, new) made, each exactly once."""
    text = PATH.read_text()
    for old, new in replacements:
        assert text.count(old) >= 1, old
        text = text.replace(old, new, 1)
    path = tmp_path / "edited.urdf"
    path.write_text(text)
    return path


LEFT_CYLINDER = '<geometry><cylinder radius="0.08" length="0.04"/></geometry>'


def test_declared_radii_give_the_rows_of_the_geometry(tmp_path, robot):
    path = edited(tmp_path, (LEFT_CYLINDER, '<geometry><box size="0.1 0.1 0.1"/></geometry>'),
                  (LEFT_CYLINDER, '<geometry><box size="0.1 0.1 0.1"/></geometry>'))
    declared = dmoc.RobotSystem(path, wheels={"left_wheel": 0.08, "right_wheel": 0.08})
    q = np.array([0.1, 0.2, 0.7, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(declared.constraint_matrix(q), robot.constraint_matrix(q))


LEFT_JOINT = '<origin xyz="-0.1 0.2 0" rpy="-1.5707963267948966 0 0"/>'


@pytest.mark.parametrize("replacements", [
    # the radius from the <visual> cylinder where the <collision> shape is a box
    [(LEFT_CYLINDER + "\n    </collision>", '<geometry><box size="0.1 0.1 0.1"/></geometry>\n'
      '    </collision>\n    <visual>' + LEFT_CYLINDER + '</visual>')],
    # the left wheel on a fixed mount turned by pi about z, 0.1 m behind the base's origin:
    # its joint's origin and rotation in the mount's frame compose to the same axle and centre
    [('<parent link="base_link"/>\n    <child link="left_wheel_link"/>',
      '<parent link="mount"/>\n    <child link="left_wheel_link"/>'),
     (LEFT_JOINT, '<origin xyz="0 -0.2 0" rpy="-1.5707963267948966 0 -3.141592653589793"/>'),
     ('<joint name="caster_mount"', '<joint name="mount_joint" type="fixed"><parent link="base_link"/>'
      '<child link="mount"/><origin xyz="-0.1 0 0" rpy="0 0 3.141592653589793"/></joint>\n'
      '  <link name="mount"/>\n  <joint name="caster_mount"')],
], ids=["visual cylinder", "fixed turned mount"])
def test_other_ways_to_the_same_wheels_give_the_same_rows(tmp_path, robot, replacements):
    other = dmoc.RobotSystem(edited(tmp_path, *replacements), wheels=WHEELS)
    q = np.array([0.1, 0.2, 0.7, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(other.constraint_matrix(q), robot.constraint_matrix(q),
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(other.mass_matrix(q), robot.mass_matrix(q), rtol=0, atol=1e-14)


@pytest.mark.parametrize("replacements, wheels, match", [
    ([], ("left_wheel", "arm_yaw"), r"wheel joint 'arm_yaw'.*axis must be horizontal"),
    ([], ("left_wheel", "castor"), r"`wheels` must name distinct moving joints.*\['castor'\] not"),
    ([], ("left_wheel", "left_wheel"), r"`wheels` must name distinct"),
    ([], "left_wheel", r"`wheels` must be a sequence"),
    ([], {"left_wheel": -0.08, "right_wheel": None},
     r"the radius of 'left_wheel' must be a number > 0"),
    ([(LEFT_CYLINDER, '<geometry><sphere radius="0.08"/></geometry>')], WHEELS,
     r"joint 'left_wheel'.*link 'left_wheel_link' has no <collision> or <visual> <cylinder>"
     r".*wheels=\{'left_wheel': r\}"),
    ([('xyz="-0.1 0.2 0" rpy="-1.5707963267948966 0 0"', 'xyz="-0.1 0.2 0" rpy="-1.4 0 0"')],
     WHEELS, r"wheel joint 'left_wheel'.*axis must be horizontal"),
    ([('<origin xyz="-0.1 0.2 0"', '<origin xyz="-0.1 0.2 0.01"')],
     WHEELS, r"must touch one ground plane.*'left_wheel' at z = -0.07, 'right_wheel' at z = -0.08"),
    ([('<origin xyz="0 0 0" rpy="0 0 0"/>\n      <geometry><cylinder',
       '<origin xyz="0 0.03 0" rpy="0 0 0"/>\n      <geometry><cylinder')],
     WHEELS, r"the collision cylinder of link 'left_wheel_link' must have a radius > 0, be "
             r"centred on the joint's axis.*centre \[0.0, 0.03, 0.0\]"),
    ([('<parent link="base_link"/>\n    <child link="left_wheel_link"/>',
       '<parent link="turret"/>\n    <child link="left_wheel_link"/>')],
     WHEELS, r"wheel joint 'left_wheel'.*fixed to the base; \['turret'\] move"),
    ([('type="continuous"', 'type="prismatic"')], WHEELS, r"joint 'left_wheel' is prismatic"),
])
def test_wheels_the_convention_does_not_cover_are_refused(tmp_path, replacements, wheels, match):
    with pytest.raises(dmoc.DmocError, match=match):
        dmoc.RobotSystem(edited(tmp_path, *replacements), wheels=wheels)


def test_a_file_with_its_own_planar_base_joint_is_refused_with_the_convention(tmp_path):
    path = edited(tmp_path, ('<link name="base_link">', '<link name="world"/>\n  <joint name="'
                             'base_joint" type="planar"><parent link="world"/><child link="'
                             'base_link"/><axis xyz="0 0 1"/></joint>\n  <link name="base_link">'))
    with pytest.raises(dmoc.InputError, match=r"joint 'base_joint'.*type 'planar'.*root link"):
        dmoc.RobotSystem(path, wheels=WHEELS)
