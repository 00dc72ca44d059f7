"""Robots from their URDF files (`dmoc.RobotSystem`) against Pinocchio, which reads the same
files with its own parser and rigid-body algorithms: the mass matrix, the gravity torques,
the bias terms C(q, v) v + G(q) and the friction of the system's Lagrangian and force equal
Pinocchio's numeric ones to 1e-12 (relative) at random states; the simulated double
pendulum and arm converge at the rule's order to DOP853 on Pinocchio's forward dynamics
(`aba`); a rest-to-rest DMOC of the arm passes its verdict and its controls, integrated by
DOP853 on Pinocchio's dynamics, reach the goal."""

import warnings

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dmoc
from dmoc.mechanics.robots import EXAMPLE_MODELS, example_urdf

pytest.importorskip("adam.casadi", reason="the robots extra (adam-robotics[casadi]) is not "
                    "installed: pip install -e '.[test]'")
pin = pytest.importorskip("pinocchio", reason="Pinocchio (pin), the tests' oracle, is not "
                          "installed: pip install -e '.[test]'")

GRAVITY = 9.81


def pinocchio_model(path, locked=()):
    """Pinocchio's model of the URDF at `path` with g = 9.81 along -z, the joints named in
    `locked` held at 0."""
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear[:] = [0.0, 0.0, -GRAVITY]
    if locked:
        model = pin.buildReducedModel(model, [model.getJointId(j) for j in locked],
                                      np.zeros(model.nq))
        model.gravity.linear[:] = [0.0, 0.0, -GRAVITY]
    return model, model.createData()


def lagrangian_terms(system):
    """(M(q), G(q), C(q, v) v + G(q), f(q, v, 0)) as Functions, each from the system's own L
    and f by differentiation: M = d2L/dv2, G = -dL/dq at v = 0, and the bias of Lagrange's
    equations d2L/dv dq v - dL/dq."""
    q, v = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n)
    L = system.lagrangian(q, v)
    dL_dv, dL_dq = ca.gradient(L, v), ca.gradient(L, q)
    bias = ca.jtimes(dL_dv, q, v) - dL_dq
    G = -ca.substitute(dL_dq, v, ca.SX.zeros(system.n))
    return (ca.Function("M", [q], [ca.hessian(L, v)[0]]), ca.Function("G", [q], [G]),
            ca.Function("b", [q, v], [bias]),
            ca.Function("f", [q, v], [system.force(q, v, ca.SX.zeros(system.n_u))]))


def close(ours, theirs):
    """Equal to 1e-12 relative to the size of Pinocchio's value (at least 1)."""
    ours, theirs = np.asarray(ours, float).reshape(np.shape(theirs)), np.asarray(theirs)
    return np.abs(ours - theirs).max() <= 1e-12 * max(1.0, np.abs(theirs).max())


def symmetric(M):
    return np.triu(M) + np.triu(M, 1).T


FIXED_BASE = sorted(set(EXAMPLE_MODELS) - {"mobile_arm", "space_arm"})   # test_mobile_robots.py, test_floating_base.py


@pytest.fixture(scope="module", params=FIXED_BASE)
def robot(request):
    path = example_urdf(request.param)
    return dmoc.RobotSystem(path), pinocchio_model(path)


def test_mass_matrix_gravity_bias_and_friction_equal_pinocchio(robot):
    system, (model, data) = robot
    M, G, bias, friction = lagrangian_terms(system)
    rng = np.random.default_rng(7)
    for _ in range(30):
        q, v = rng.uniform(-np.pi, np.pi, system.n), rng.uniform(-3, 3, system.n)
        assert close(M(q), symmetric(pin.crba(model, data, q)))
        assert close(system.mass_matrix(q), symmetric(pin.crba(model, data, q)))
        assert close(G(q), pin.computeGeneralizedGravity(model, data, q))
        assert close(bias(q, v), pin.nonLinearEffects(model, data, q, v))
        assert close(friction(q, v), -model.damping * v)


def test_limits_and_names_are_the_files(robot):
    system, (model, _) = robot
    assert system.names == tuple(model.names[1:])
    np.testing.assert_array_equal(system.position_limits[0], model.lowerPositionLimit)
    np.testing.assert_array_equal(system.position_limits[1], model.upperPositionLimit)
    np.testing.assert_array_equal(system.effort_limits[1], model.effortLimit)
    np.testing.assert_array_equal(system.effort_limits[0], -model.effortLimit)
    np.testing.assert_array_equal(system.velocity_limits, model.velocityLimit)
    assert system.units["u"] == ("N m",) * system.n and system.units["q"] == ("rad",) * system.n


def test_chosen_joints_move_and_the_others_are_held_at_zero():
    """`joints=`: the arm with its shoulder lift and elbow only equals Pinocchio's model
    reduced with the other four joints locked at 0, in the order asked for."""
    path, chosen = example_urdf("arm6"), ["elbow", "shoulder_lift"]
    system = dmoc.RobotSystem(path, chosen, friction=[0.3, 0.0])
    model, data = pinocchio_model(path, locked=["shoulder_pan", "wrist_1", "wrist_2", "wrist_3"])
    swap = [1, 0]                 # Pinocchio keeps the file's order: shoulder_lift, elbow
    M, G, bias, friction = lagrangian_terms(system)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, v = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)
        assert close(M(q), symmetric(pin.crba(model, data, q[swap]))[np.ix_(swap, swap)])
        assert close(bias(q, v), pin.nonLinearEffects(model, data, q[swap], v[swap])[swap])
        assert close(friction(q, v), -np.array([0.3, 0.0]) * v)


def test_a_file_omitting_what_the_specification_defaults_equals_pinocchio(tmp_path):
    """The URDF specification lets a joint omit its <origin> (identity) and <axis> (x) and
    an <inertial> its <origin>; adam 0.5 fails on such files unless dmoc writes the
    defaults out for it."""
    text = example_urdf("double_pendulum").read_text()
    text = text.replace('<origin xyz="0 0 0" rpy="0 0 0"/>', "", 1)            # shoulder
    text = text.replace('<axis xyz="0 1 0"/>', "", 1)                           # shoulder
    text = text.replace('<origin xyz="0 0 -0.5" rpy="0 0 0"/>', "", 1)         # upper rod
    assert text.count("<origin") == 2 and text.count("<axis") == 1
    path = tmp_path / "defaults.urdf"
    path.write_text(text)
    system, (model, data) = dmoc.RobotSystem(path), pinocchio_model(path)
    M, _, bias, _ = lagrangian_terms(system)
    rng = np.random.default_rng(5)
    for _ in range(10):
        q, v = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)
        assert close(M(q), symmetric(pin.crba(model, data, q)))
        assert close(bias(q, v), pin.nonLinearEffects(model, data, q, v))


MIXED_TREE_URDF = """<?xml version="1.0"?>
<robot name="mixed_tree">
  <link name="base">
    <inertial><origin xyz="0.02 -0.01 0.05" rpy="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.025"/></inertial>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="base"/><child link="carriage"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.2 0.5"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-0.5" upper="0.5" velocity="1" effort="100"/>
  </joint>
  <link name="carriage">
    <inertial><origin xyz="0.05 0.02 -0.1" rpy="0.1 0.2 -0.3"/><mass value="1.5"/>
      <inertia ixx="0.012" ixy="0.001" ixz="-0.002" iyy="0.015" iyz="0.0015" izz="0.01"/></inertial>
  </link>
  <joint name="turn" type="revolute">
    <parent link="carriage"/><child link="arm"/>
    <origin xyz="0 0.2 -0.1" rpy="-0.4 0.1 0.2"/><axis xyz="0.48 0.6 0.64"/>
    <limit lower="-3" upper="3" velocity="3" effort="50"/>
  </joint>
  <link name="arm">
    <inertial><origin xyz="0.15 0 0.03" rpy="0 -0.3 0.1"/><mass value="1.2"/>
      <inertia ixx="0.004" ixy="0.0002" ixz="0" iyy="0.02" iyz="-0.0003" izz="0.021"/></inertial>
  </link>
  <joint name="flap_hinge" type="revolute">
    <parent link="carriage"/><child link="flap"/>
    <origin xyz="-0.1 0 0.05" rpy="0 0.7 0"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" velocity="3" effort="10"/>
  </joint>
  <link name="flap">
    <inertial><origin xyz="0 0.08 0" rpy="0 0 0"/><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.0004" iyz="0" izz="0.0012"/></inertial>
  </link>
  <joint name="hand_mount" type="fixed">
    <parent link="arm"/><child link="hand"/><origin xyz="0.3 0.01 0" rpy="1.2 0 -0.4"/>
  </joint>
  <link name="hand">
    <inertial><origin xyz="0 0 0.02" rpy="0.2 0 0"/><mass value="0.3"/>
      <inertia ixx="0.0003" ixy="0" ixz="0.00002" iyy="0.0002" iyz="0" izz="0.00025"/></inertial>
  </link>
  <joint name="wrist" type="revolute">
    <parent link="arm"/><child link="wrist_frame"/>
    <origin xyz="0.3 0 0" rpy="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="3" effort="20"/>
  </joint>
  <link name="wrist_frame"/>
  <joint name="reach" type="prismatic">
    <parent link="wrist_frame"/><child link="tip"/>
    <origin xyz="0 0.05 0" rpy="0.5 0 0"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.2" velocity="1" effort="30"/>
  </joint>
  <link name="tip">
    <inertial><origin xyz="0.02 0 0" rpy="0 0 0"/><mass value="0.4"/>
      <inertia ixx="0.0002" ixy="0" ixz="0" iyy="0.0005" iyz="0" izz="0.0005"/></inertial>
  </link>
</robot>
"""


def test_a_branched_tree_of_prismatic_and_revolute_joints_equals_pinocchio(tmp_path):
    """M(q) = d2L/dv2 of the recursion's Lagrangian, the gravity and the bias terms equal
    Pinocchio's on a tree that branches (the carriage carries the arm and a flap) and
    exercises every term of the recursion: prismatic joints along tilted axes, a revolute
    joint about a non-coordinate axis, rotated joint origins and inertial frames, products
    of inertia, a fixed joint and a massless link between two moving joints."""
    path = tmp_path / "mixed_tree.urdf"
    path.write_text(MIXED_TREE_URDF)
    system, (model, data) = dmoc.RobotSystem(path), pinocchio_model(path)
    assert [j.kind for j in system.joints] == ["prismatic", "revolute", "revolute",
                                               "revolute", "prismatic"]
    order = [list(model.names).index(name) - 1 for name in system.names]   # ours -> theirs
    M, G, bias, _ = lagrangian_terms(system)
    rng = np.random.default_rng(11)
    for _ in range(10):
        q, v = rng.uniform(-1, 1, system.n), rng.uniform(-2, 2, system.n)
        q_pin, v_pin = np.empty(system.n), np.empty(system.n)
        q_pin[order], v_pin[order] = q, v
        theirs = symmetric(pin.crba(model, data, q_pin))[np.ix_(order, order)]
        assert close(M(q), theirs)
        assert close(system.mass_matrix(q), theirs)
        assert close(G(q), pin.computeGeneralizedGravity(model, data, q_pin)[order])
        assert close(bias(q, v), pin.nonLinearEffects(model, data, q_pin, v_pin)[order])


# ---------------------------------------------------------------------------------------
# Simulation against DOP853 on Pinocchio's forward dynamics

def pinocchio_final_state(path, q0, v0, controls, h):
    """(q, v) at the end of piecewise constant torques `controls` (N, n) held over steps
    h, by DOP853 on q'' = aba(q, v, u - D v), D Pinocchio's damping from the file."""
    model, data = pinocchio_model(path)
    n, y = len(q0), np.concatenate([q0, v0])
    for u in controls:
        def rhs(t, y, u=u):
            q, v = y[:n], y[n:]
            return np.concatenate([v, pin.aba(model, data, q, v, u - model.damping * v)])
        y = solve_ivp(rhs, (0, h), y, method="DOP853", rtol=1e-13, atol=1e-12).y[:, -1]
    return y[:n], y[n:]


def final_error(system, rule, q0, v0, u, T, steps):
    disc = dmoc.discretize(system, T / steps, rule)
    result = dmoc.simulate(disc, q0=q0, v0=v0, steps=steps, controls=np.tile(u, (steps, 1)))
    return result.trajectory.q[-1]


CONVERGENCE = {   # model: (q0, v0, constant torques u, T)
    "double_pendulum": ([0.8, -0.5], [0.0, 1.0], [0.5, -0.2], 1.0),
    "arm6": ([0.1, -0.6, 1.0, -0.4, 0.3, 0.0], [0.5, 0.0, -0.5, 0.3, 0.0, 1.0],
             [2.0, 10.0, 5.0, 0.5, 0.1, 0.01], 0.5),
    "arm7": ([0.1, -0.3, 0.2, -1.8, 0.1, 1.5, 0.3], [0.3, 0.0, -0.3, 0.2, 0.0, 0.5, 1.0],
             [1.0, 5.0, 2.0, -3.0, 0.2, 0.5, 0.05], 0.5),
}


@pytest.mark.parametrize("rule, order, steps", [("midpoint", 2, [20, 40, 80]),
                                                ("lobatto3", 4, [10, 20, 40])])
@pytest.mark.parametrize("name", sorted(CONVERGENCE))
def test_converges_to_dop853_on_pinocchio_at_the_rule_order(name, rule, order, steps):
    path = example_urdf(name)
    q0, v0, u, T = (np.array(x, float) for x in CONVERGENCE[name])
    q_ref, _ = pinocchio_final_state(path, q0, v0, [u], T)
    system = dmoc.RobotSystem(path)
    errors = [np.abs(final_error(system, rule, q0, v0, u, T, N) - q_ref).max() for N in steps]
    slope = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.35, (errors, slope)
    assert errors[-1] < 0.01 * np.abs(q_ref - q0).max(), errors      # within 1 % of the motion


# ---------------------------------------------------------------------------------------
# Optimal control

REST_TO_REST = {   # model: (q_start, q_goal), within the file's limits; arm7 kept away from
    # joint2 = 0, where the axes of joints 1 and 3 align and q1 - q3 turns only the
    # slender link2 about its long axis: a fast mode N = 20 steps do not resolve (a defect
    # of 4e-2 rad in a motion through joint2 = 0)
    "arm6": ([0.0, -0.5, 1.0, -0.5, 0.0, 0.0], [0.5, -0.8, 1.2, -0.3, 0.3, 0.2]),
    "arm7": ([0.0, -0.8, 0.0, -2.2, 0.0, 1.7, 0.8], [0.5, -1.1, -0.3, -1.8, 0.3, 1.9, 0.5]),
}


@pytest.mark.parametrize("name", sorted(REST_TO_REST))
def test_rest_to_rest_motion_of_the_arm_passes_and_follows_pinocchio(name):
    """N = 20 steps over 1 s within the file's position and torque limits; cost u^T u +
    10 v^T v (u^T u alone leaves the light last wrist nearly free and the grid does not
    resolve its motion: verdict "under_resolved"). Each step of the optimum, from
    (q_k, v_k = M(q_k)^-1 p_k) with its torque held, agrees with DOP853 on Pinocchio's
    dynamics to the rule's local error O(h^3): measured 1.4e-3 rad (arm6) and 3.9e-3 rad
    (arm7) at h = 0.05, against the 1 % of the motion (5e-3 rad) asked; a wrong sign of
    gravity alone would put g h^2 / 2 = 1.2e-2 rad into a step."""
    arm, path = dmoc.RobotSystem(example_urdf(name)), example_urdf(name)
    q_start, q_goal = (np.array(x) for x in REST_TO_REST[name])
    N, h = 20, 0.05
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(arm, h), N, q_start=q_start, q_goal=q_goal, v_start=np.zeros(arm.n),
        control_bounds=arm.effort_limits, state_bounds=arm.position_limits,
        running_cost=lambda q, v, u: ca.sumsqr(u) + 10 * ca.sumsqr(v))
    result = dmoc.optimize(problem)
    assert result.success and result.verdict.status == "passed"
    traj = result.trajectory
    assert (np.abs(traj.u) <= arm.effort_limits[1] + 1e-9).all()
    np.testing.assert_allclose(traj.q[-1], q_goal, atol=1e-9)
    defects = []
    for k in range(N):
        v = np.linalg.solve(symmetric(pin.crba(*pinocchio_model(path), traj.q[k])), traj.p[k])
        q_next, _ = pinocchio_final_state(path, traj.q[k], v, [traj.u[k]], h)
        defects.append(np.abs(q_next - traj.q[k + 1]).max())
    assert max(defects) < 0.01 * np.abs(q_goal - q_start).max(), defects


# ---------------------------------------------------------------------------------------
# Failures explained, bad input

def test_a_step_too_large_for_the_motion_is_explained():
    pendulum = dmoc.RobotSystem(example_urdf("double_pendulum"))
    with pytest.raises(dmoc.SolverError) as failure:
        dmoc.simulate(dmoc.discretize(pendulum, 0.1), q0=[2.0, 1.0], v0=[20.0, -30.0], steps=200)
    message = str(failure.value)
    assert "velocities at the last accepted step: shoulder" in message
    assert "h = 0.1 is too large for the fastest motion" in message
    assert failure.value.result.status == "newton_failed"


def test_joint_friction_is_not_taken_for_the_fastest_motion():
    """arm6's damping (0.05 N m s on the wrists, whose inertia about the axis is 2.3e-4
    kg m^2: a friction rate of 218/s) pushed by torques past what h = 0.05 resolves: the
    hint names the rate of the motion, the largest joint speed or gravity mode read from
    Pinocchio at the last accepted state (friction, linear in v, adds -D/2 to the step's
    Jacobian, the sign of -M/h, and never makes a step harder), and at the h it advises
    the same 1.2 s converges. Before, it named the friction rate and advised h <= 0.0011."""
    path = example_urdf("arm6")
    arm, (model, data) = dmoc.RobotSystem(path), pinocchio_model(path)
    start = dict(q0=[0.1, -0.6, 1.0, -0.4, 0.3, 0.0], v0=[0.5, 0.0, -0.5, 0.3, 0.0, 1.0])
    u = [2.0, 10.0, 5.0, 0.5, 0.1, 0.01]
    failed = dmoc.simulate(dmoc.discretize(arm, 0.05), steps=24, controls=np.tile(u, (24, 1)),
                           throw=False, jit=False, **start)
    assert failed.status == "newton_failed"
    q, p = failed.trajectory.q[-1], failed.trajectory.p[-1]
    M = symmetric(pin.crba(model, data, q))
    K = pin.computeGeneralizedGravityDerivatives(model, data, q)
    rate = max(np.abs(np.linalg.solve(M, p)).max(),
               np.sqrt(np.abs(np.linalg.eigvals(np.linalg.solve(M, K))).max()))
    assert np.abs(np.linalg.eigvals(np.linalg.solve(M, np.diag(model.damping)))).max() > 2 * rate
    assert f"(h times its rate {rate:.3g}/s is {0.05 * rate:.2g})" in failed.message
    advised = float(failed.message.split("take h <= ")[1].split(",")[0])
    steps = int(round(1.2 / advised))
    assert dmoc.simulate(dmoc.discretize(arm, advised), steps=steps, jit=False,
                         controls=np.tile(u, (steps, 1)), **start).success


NEAR_SINGULAR_URDF = """<?xml version="1.0"?>
<robot name="weightless_forearm">
  <link name="base"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" velocity="10" effort="10"/>
  </joint>
  <link name="upper">
    <inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
      <inertia ixx="0.08" ixy="0" ixz="0" iyy="0.08" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="lower"/><origin xyz="0 0 -1"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" velocity="10" effort="10"/>
  </joint>
  <link name="lower">
    <inertial><origin xyz="0 0 -0.0001"/><mass value="0.1"/>
      <inertia ixx="1e-10" ixy="0" ixz="0" iyy="1e-10" iyz="0" izz="1e-10"/></inertial>
  </link>
</robot>
"""


def test_a_near_singular_inertia_is_named(tmp_path):
    """A forearm whose mass sits 0.1 mm from the elbow's axis with (almost) no inertia
    about it: M(q) has condition number 5e8, and a torque on the elbow spins it up at
    1e9 rad/s^2."""
    path = tmp_path / "weightless_forearm.urdf"
    path.write_text(NEAR_SINGULAR_URDF)
    system = dmoc.RobotSystem(path)
    controls = np.tile([0.0, 1.0], (50, 1))
    result = dmoc.simulate(dmoc.discretize(system, 0.01), q0=[0.3, 0.0], v0=[0.0, 0.0],
                           steps=50, controls=controls, throw=False)
    assert result.status == "newton_failed"
    assert "M(q) has condition number 5e+08" in result.message
    assert "likely cause: near-singular inertia" in result.message


THIN_TIP_URDF = """<?xml version="1.0"?>
<robot name="thin_tip"><link name="base"/>
<joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
  <axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="3" effort="100"/></joint>
<link name="arm"><inertial><origin xyz="0 0 -0.15"/><mass value="3"/>
  <inertia ixx="0.0237" ixy="0" ixz="0" iyy="0.0237" iyz="0" izz="0.0024"/></inertial></link>
<joint name="tip_roll" type="revolute"><parent link="arm"/><child link="tip"/>
  <origin xyz="0 0 -0.3"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="3" effort="1"/></joint>
<link name="tip"><inertial><origin xyz="0 0 -0.15"/><mass value="1e-3"/>
  <inertia ixx="7.5e-6" ixy="0" ixz="0" iyy="7.5e-6" iyz="0" izz="5e-12"/></inertial></link>
</robot>"""


def test_a_light_thin_tip_leaves_the_robot_regular(tmp_path):
    """A 3 kg arm carrying a 1 g tip of radius 0.1 mm that rolls about its own axis:
    M(q) = diag(0.0237 + 3 0.15^2 + 7.5e-6 + 1e-3 0.45^2, 5e-12) (the roll's axis is the
    tip's symmetry axis, so nothing couples it to the shoulder), positive definite with
    condition number 1.8e10. The Lagrangian is regular: lobatto3 keeps its order 4, and
    neither `discretize` nor a midpoint run warns (a relative rank tolerance of 1e-10 on
    M called it degenerate, and a 6-joint chain with such a tip got a ParasiticModeWarning
    advising the midpoint rule it was run with)."""
    path = tmp_path / "thin_tip.urdf"
    path.write_text(THIN_TIP_URDF)
    robot = dmoc.RobotSystem(path)
    M = np.diag([0.0237 + 3 * 0.15 ** 2 + 7.5e-6 + 1e-3 * 0.45 ** 2, 5e-12])
    for q in ([0.1, 0.1], [-0.7, 2.0]):
        np.testing.assert_allclose(np.array(robot.mass_matrix(q)), M, rtol=1e-12, atol=1e-22)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert dmoc.discretize(robot, 0.005, "lobatto3").order == 4
        assert dmoc.simulate(dmoc.discretize(robot, 0.005), q0=[0.1, 0.1], v0=[0.0, 0.0], steps=5).success


@pytest.mark.parametrize("call, match", [
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), ["elbow", "knee"]), r"`joints`.*'knee'"),
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), ["elbow", "elbow"]), r"`joints` must be distinct"),
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), "elbow"), r"`joints` must be a sequence"),
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), [3]), r"`joints`.*\[3\] not among them"),
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), friction=-1.0), r"`friction`"),
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), friction=[0.1, 0.2]), r"`friction` must have shape \(6,\)"),
    (lambda: dmoc.RobotSystem(example_urdf("arm6"), gravity=float("nan")), r"`gravity`"),
    (lambda: dmoc.RobotSystem("no/such/robot.urdf"), r"`path` must be an existing file"),
    (lambda: example_urdf("panda"), r"`name` must be one of 'double_pendulum', 'arm6'"),
])
def test_bad_arguments_name_the_argument(call, match):
    with pytest.raises(dmoc.DmocError, match=match):
        call()


@pytest.mark.parametrize("text, match", [
    ("<robot name='r'><link name='a'/></robot>", "has none"),
    ("<model/>", "root element <robot>"),
    ("<robot", "does not parse"),
    ("<robot name='r'><joint name='base' type='floating'/></robot>", "type 'floating'.*FloatingBaseRobot"),
    ("<robot name='r'><joint name='j' type='revolute'><limit lower='1' upper='-1'/></joint></robot>",
     "lower < upper"),
    ("<robot name='r'><joint name='j' type='revolute'><axis xyz='0 0 0'/></joint></robot>",
     "must be a nonzero vector"),
    ("<robot name='r'><joint name='j' type='revolute'><axis xyz='0 1'/></joint></robot>",
     "must be three numbers"),
])
def test_files_dmoc_cannot_take_are_refused_with_the_reason(tmp_path, text, match):
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    with pytest.raises(dmoc.InputError, match=match):
        dmoc.RobotSystem(path)


def test_without_adam_the_message_names_the_extra(monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "adam.casadi", None)
    with pytest.raises(ModuleNotFoundError, match=r"dmoc\[robots\]"):
        dmoc.RobotSystem(example_urdf("double_pendulum"))


# ---------------------------------------------------------------------------------------
# The second variation of L by spatial algebra, and the step's Jacobian from it


def second_variation_blocks(system):
    """(L_qq, L_qv, M) from the system's `second_variation` along unit directions, as one
    Function of (q, v)."""
    q, v = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n)
    blocks = [system.second_variation(q, v, a, b) for a, b in (((1, 0), (1, 0)), ((1, 0), (0, 1)),
                                                               ((0, 1), (0, 1)))]
    return ca.Function("blocks", [q, v], blocks)


def test_the_second_variation_equals_pinocchio_and_the_hessian_of_l(tmp_path):
    """On the branched tree of prismatic and revolute joints (every term of the formulas:
    tilted axes, rotated frames, products of inertia, a fixed joint, a massless link): M
    equals Pinocchio's CRBA, d^2L/dv dq = d(M(q) a)/dq at a = v Pinocchio's RNEA derivative
    (no gravity, zero velocity), d^2V/dq^2 its gravity derivative, and every block, and a
    combination with arbitrary weights, the Hessian of the recursion's L by automatic
    differentiation, to 1e-12."""
    path = tmp_path / "mixed_tree.urdf"
    path.write_text(MIXED_TREE_URDF)
    system, (model, data) = dmoc.RobotSystem(path), pinocchio_model(path)
    free = pin.buildModelFromUrdf(str(path))
    free.gravity.linear[:] = 0.0
    free_data = free.createData()
    order = [list(model.names).index(name) - 1 for name in system.names]   # ours -> theirs
    blocks = second_variation_blocks(system)
    q, v = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n)
    H = ca.Function("H", [q, v], [ca.hessian(system.lagrangian(q, v), ca.vertcat(q, v))[0]])
    weights = ((0.3, -1.7), (2.1, 0.4))
    combined = ca.Function("W", [q, v], [system.second_variation(q, v, *weights)])
    n, rng = system.n, np.random.default_rng(12)
    for _ in range(10):
        q0, v0 = rng.uniform(-1, 1, n), rng.uniform(-2, 2, n)
        q_pin, v_pin = np.empty(n), np.empty(n)
        q_pin[order], v_pin[order] = q0, v0
        L_qq, L_qv, M = (np.array(b) for b in blocks(q0, v0))
        mixed = order, order
        assert close(M, symmetric(pin.crba(model, data, q_pin))[np.ix_(*mixed)])
        dtau_dq = pin.computeRNEADerivatives(free, free_data, q_pin, np.zeros(n), v_pin)[0]
        assert close(L_qv.T, np.array(dtau_dq)[np.ix_(*mixed)])
        gravity = pin.computeGeneralizedGravityDerivatives(model, data, q_pin)
        at_rest = np.array(blocks(q0, np.zeros(n))[0])
        assert close(-at_rest, np.array(gravity)[np.ix_(*mixed)])
        hessian = np.array(H(q0, v0))
        assert close(L_qq, hessian[:n, :n]) and close(L_qv, hessian[:n, n:]) and close(M, hessian[n:, n:])
        (a_q, a_v), (b_q, b_v) = weights
        expected = (a_q * b_q * hessian[:n, :n] + a_q * b_v * hessian[:n, n:]
                    + a_v * b_q * hessian[n:, :n] + a_v * b_v * hessian[n:, n:])
        assert close(np.array(combined(q0, v0)), expected)


@pytest.mark.parametrize("name, variant", [("arm6", "+"), ("arm6", "-"), ("mixed_tree", "+")])
def test_the_step_jacobian_from_the_second_variation_equals_automatic_differentiation(name, variant,
                                                                                      tmp_path):
    """The chord's Jacobian of the midpoint step (h/4 L_qq + (L_qv - L_qv^T)/2 - M/h and the
    friction's term) equals CasADi's Jacobian of the step equations of either formulation to
    1e-12 at random states, increments, torques and steps h; a wheeled robot falls back to it."""
    from dmoc.principle.residual import step_residual
    from dmoc.simulation.step_jacobian import step_jacobian
    from dmoc.simulation.stepper import DiracStepper
    if name == "mixed_tree":
        path = tmp_path / "mixed_tree.urdf"
        path.write_text(MIXED_TREE_URDF)
    else:
        path = example_urdf(name)
    system = dmoc.RobotSystem(path, friction=0.4)
    stepper = DiracStepper(step_residual(dmoc.discretize(system, 0.01), variant), 1e-12, 50)
    params = stepper.symbols(ca.SX)[3]
    y = ca.SX.sym("y", system.n)
    g = stepper.equations(y, params)[0]
    ours = ca.Function("J", [y, params], [step_jacobian(stepper, g, y, params)])
    automatic = ca.Function("J", [y, params], [ca.jacobian(g, y)])
    assert ours.n_instructions() != automatic.n_instructions()      # not the fallback
    rng = np.random.default_rng(13)
    for h in (0.003, 0.01, 0.05):
        for _ in range(5):
            state = np.concatenate([rng.uniform(-2, 2, system.n), rng.uniform(-3, 3, system.n),
                                    rng.uniform(-10, 10, system.n_u), [h]])
            increment = rng.uniform(-0.1, 0.1, system.n)
            assert close(np.array(ours(increment, state)), np.array(automatic(increment, state)))
    wheeled = dmoc.RobotSystem(example_urdf("mobile_arm"), wheels=("left_wheel", "right_wheel"))
    assert wheeled.second_variation(ca.SX.sym("q", 8), ca.SX.sym("v", 8), (1, 0), (1, 0)) is None
