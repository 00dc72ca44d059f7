"""Every error a user can cause is a `dmoc.DmocError` (docs/errors.md).

Oracles, none taken from the code under test:
- the bad inputs are the rows of docs/verification.md, "Bad inputs" (the API table, and the
  command-line rows whose bad value reaches an API call), each fed here to its entry point;
  each must raise a `DmocError` that is still the built-in class the table names
  (`InputError` and `TrajectoryFileError` a ValueError, `InputTypeError` a TypeError) and
  whose message says what the table says;
- plain bad input at the other entry points (None for the object, a wrong column, a
  series of the wrong length, a path that is not one) must be a `DmocError` too, naming the
  argument, where numpy, matplotlib or the os module would otherwise raise their own error;
- the source of dmoc/ is read with `ast`: no `raise ValueError(...)` or
  `raise TypeError(...)` may remain outside the validation layer `dmoc/_util/checks.py`.
"""

import ast
import math
import pathlib
from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import animation, batch, diagnostics, plotting
from dmoc.discrete.quadrature_rules import QuadratureRule
from dmoc.drivers.accuracy import optimize_to_accuracy
from dmoc.drivers.error_estimate import estimate_error
from dmoc.systems import knife_edge

Q0, V0 = [0.0, 0.0, 0.3], [np.cos(0.3), np.sin(0.3), 1.0]
START, GOAL = [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]
UNREACHABLE = "tcp://127.0.0.1:1"       # batch checks its arguments before connecting


@pytest.fixture(scope="module")
def ctx(tmp_path_factory):
    """The knife edge's discretization, a short trajectory and a folder of damaged files."""
    disc = dmoc.discretize(knife_edge(), 0.1)
    traj = dmoc.simulate(disc, q0=Q0, v0=V0, steps=4).trajectory
    folder = tmp_path_factory.mktemp("taxonomy")
    traj.save(folder / "good.npz")
    data = (folder / "good.npz").read_bytes()
    (folder / "trunc.npz").write_bytes(data[: len(data) // 2])
    (folder / "empty.npz").write_bytes(b"")
    (folder / "rand.npz").write_bytes(np.random.default_rng(0).bytes(2000))
    np.savez(folder / "foreign.npz", a=np.zeros(3))
    np.save(folder / "one.npy", np.zeros(3))
    (folder / "plain").write_text("x")
    return SimpleNamespace(disc=disc, traj=traj, folder=folder)


def simulate(ctx, **changes):
    """simulate() on valid knife-edge data with some arguments replaced (None drops one)."""
    kwargs = {"q0": Q0, "v0": V0, "steps": 5, **changes}
    return dmoc.simulate(ctx.disc, **{k: v for k, v in kwargs.items() if v is not None})


def closed_client():
    """A distributed.Client of an in-process cluster without workers, closed. Clients of
    earlier rows are collected first: a Client finalized by a garbage collection that runs
    inside the new Client's start stops the shared loop runner it is starting and hangs
    (seen once in CI, distributed 2026.8.0: Client.__del__ under LoopRunner.start)."""
    import gc
    import distributed
    gc.collect()
    with distributed.Client(processes=False, n_workers=0, dashboard_address=":0") as client:
        return client


def problem(ctx, steps=5, **changes):
    """OptimalControlProblem on the knife edge with some arguments replaced."""
    return dmoc.OptimalControlProblem(ctx.disc, steps, **{"q_start": START, "q_goal": GOAL, **changes})


def _stepped(controller):
    """`controller` after one step from rest at START."""
    controller.step(START, p=START)
    return controller


def sphere_roll():
    """The Chaplygin sphere (r = 1) rolled from rest at (I, 0) along e1 by 1 m in 4 steps,
    turning 1 rad about e2."""
    disc = dmoc.discretize(dmoc.systems.chaplygin_sphere(torques=True), 0.25)
    turned = np.array([[np.cos(1.0), 0.0, np.sin(1.0)], [0.0, 1.0, 0.0], [-np.sin(1.0), 0.0, np.cos(1.0)]])
    return dmoc.GroupOptimalControlProblem(disc, 4, R_start=np.eye(3), R_goal=turned,
                                           x_start=[0.0, 0.0], x_goal=[1.0, 0.0])


def _rolled(controller):
    """`controller` (of `sphere_roll`) after one step from its start at rest."""
    controller.step((np.eye(3), [0.0, 0.0]), v=[0.0] * 5)
    return controller


def _nan_rotation():
    R = np.eye(3)
    R[1, 2] = np.nan
    return R


def trajectory(**changes):
    """Trajectory(...) of 2 steps, n = 1, with some fields replaced."""
    kwargs = dict(t=[0.0, 0.5, 1.0], q=[[0.0], [1.0], [2.0]], p=[[0.0]] * 3, lam=[[], []],
                  u=[[1.0], [2.0]], h=0.5, variant="+")
    return dmoc.Trajectory(**{**kwargs, **changes})


def kinetic(q, v):
    return 0.5 * ca.dot(v, v)


def parametric(ctx):
    return problem(ctx, parameters={"r": 4.0},
                   running_cost=lambda q, v, u, w: u[0] ** 2 + w["r"] * u[1] ** 2)


def solved(ctx):
    """The optimum of `problem(ctx)` (5 steps: IPOPT's, not judged; too coarse for the
    verdict, which these rows do not test)."""
    return dmoc.optimize(problem(ctx), options={"print_level": 0, "sb": "yes"}, check=False)


def free_multipliers():
    """A knife-edge-sized trajectory without multiplier columns (the knife edge has 1)."""
    return dmoc.Trajectory(0.1 * np.arange(3.0), np.zeros((3, 3)), np.zeros((3, 3)),
                           np.zeros((2, 0)), np.zeros((2, 2)), 0.1, "+")


_stray = ca.SX.sym("stray")

# (id naming the table row, call of ctx, built-in class the row names, words of its message)
API_ROWS = [
    ("simulate: q0 of shape (2,)", lambda c: simulate(c, q0=[0.0, 0.0]), ValueError,
     r"`q0` must have shape \(3,\)"),
    ("simulate: v0 of shape (3, 1)", lambda c: simulate(c, v0=np.zeros((3, 1))), ValueError,
     r"`v0` must have shape \(3,\)"),
    ("simulate: controls with 4 rows for 5 steps", lambda c: simulate(c, controls=np.zeros((4, 2))),
     ValueError, r"`controls` must have shape \(5, 2\)"),
    ("simulate: p0 of shape (2,)", lambda c: simulate(c, v0=None, p0=[1.0, 0.0]), ValueError,
     r"`p0` must have shape \(3,\)"),
    ("simulate: NaN in q0", lambda c: simulate(c, q0=[0.0, np.nan, 0.3]), ValueError,
     "`q0` must be finite"),
    ("simulate: Inf in controls", lambda c: simulate(c, controls=np.full((5, 2), np.inf)),
     ValueError, "`controls` must be finite"),
    ('simulate: q0="abc"', lambda c: simulate(c, q0="abc"), TypeError, "`q0` must be an array"),
    ("simulate: q0 of booleans", lambda c: simulate(c, q0=[True, False, True]), TypeError,
     "`q0` .*bool"),
    ("simulate: symbolic q0 (casadi.SX)", lambda c: simulate(c, q0=ca.SX.sym("q", 3)), TypeError,
     "`q0` .*symbolic SX"),
    ("simulate: complex q0", lambda c: simulate(c, q0=[0, 0, 1j]), TypeError, "`q0` .*complex"),
    ("simulate: ragged controls (midpoint)", lambda c: simulate(c, steps=3, controls=[[0, 0], [0], [0, 0]]),
     ValueError, "`controls` .*ragged"),
    ('simulate: variant="plus"', lambda c: simulate(c, variant="plus"), ValueError,
     r"`variant` must be one of '\+', '-'"),
    ("simulate: both v0 and p0", lambda c: simulate(c, p0=[1.0, 0.0, 1.0]), ValueError,
     "exactly one of `v0`"),
    ("simulate: steps=2.5", lambda c: simulate(c, steps=2.5), ValueError,
     "`steps` must be a positive integer"),
    ("simulate: steps=True", lambda c: simulate(c, steps=True), ValueError,
     "`steps` must be a positive integer"),
    ("simulate: tol=0", lambda c: simulate(c, tol=0), ValueError, "`tol` must be finite and positive"),
    ("simulate: max_iter=1.5", lambda c: simulate(c, max_iter=1.5), ValueError,
     "`max_iter` must be a positive integer"),
    ("simulate: a MechanicalSystem for disc",
     lambda c: dmoc.simulate(knife_edge(), q0=Q0, v0=V0, steps=5), TypeError,
     "`disc` must be a Discretization; got MechanicalSystem"),
    ("simulate: v0 off the constraint by 1e-6",
     lambda c: simulate(c, v0=[np.cos(0.3), np.sin(0.3) + 1e-6, 1.0]), ValueError,
     "`v0` violates the velocity constraints"),
    ('discretize: rule="euler"', lambda c: dmoc.discretize(knife_edge(), 0.1, "euler"), ValueError,
     "`rule` must be one of 'midpoint'"),
    ("discretize: h=nan", lambda c: dmoc.discretize(knife_edge(), np.nan), ValueError,
     "`h` must be finite and positive"),
    ('discretize: h="0.1"', lambda c: dmoc.discretize(knife_edge(), "0.1"), TypeError,
     "`h` must be a real number"),
    ("discretize: a string for system", lambda c: dmoc.discretize("knife", 0.1), TypeError,
     "`system` must be a MechanicalSystem"),
    ("QuadratureRule without quadrature points", lambda c: QuadratureRule("empty", 2), ValueError,
     "`points` must be"),
    ("QuadratureRule with degenerate_order above order",
     lambda c: QuadratureRule("x", 2, (0.0, 1.0), ((0.5, 1.0),), degenerate_order=4), ValueError,
     "`degenerate_order` must not exceed `order`"),
    ("MechanicalSystem: vector-valued Lagrangian", lambda c: dmoc.MechanicalSystem(lambda q, v: v, 3),
     ValueError, r"`lagrangian` must return shape \(1, 1\)"),
    ("MechanicalSystem: A(q) with 2 columns for n = 3",
     lambda c: dmoc.MechanicalSystem(kinetic, 3, constraints=lambda q: ca.horzcat(1, 0)), ValueError,
     r"`constraints` must return shape \(k, 3\)"),
    ("MechanicalSystem: force of size 2 for n = 3",
     lambda c: dmoc.MechanicalSystem(kinetic, 3, force=lambda q, v, u: ca.vertcat(1, 2)), ValueError,
     r"`force` must return shape \(3, 1\)"),
    ("MechanicalSystem: undeclared symbol in L",
     lambda c: dmoc.MechanicalSystem(lambda q, v: kinetic(q, v) + _stray * q[0], 2), ValueError,
     "`lagrangian` uses symbols that are not its arguments"),
    ("MechanicalSystem: dependent constraint rows",
     lambda c: dmoc.MechanicalSystem(kinetic, 3, constraints=lambda q: ca.vertcat(
         ca.horzcat(1, 0, q[0]), ca.horzcat(2, 0, 2 * q[0]))), ValueError,
     "`constraints` must have linearly independent rows"),
    ("MechanicalSystem: n=1.5", lambda c: dmoc.MechanicalSystem(kinetic, 1.5), ValueError,
     "`n` must be a positive integer"),
    ('MechanicalSystem: names=("x", "x", "theta")',
     lambda c: dmoc.MechanicalSystem(kinetic, 3, names=("x", "x", "theta")), ValueError,
     r"`names` must be distinct .*\['x'\] more than once"),
    ('MechanicalSystem: a name "x,1"',
     lambda c: dmoc.MechanicalSystem(kinetic, 3, names=("x,1", "y", "theta")), ValueError,
     "`names` must not contain commas"),
    ("MechanicalSystem: math.sin(q[0]) in L",
     lambda c: dmoc.MechanicalSystem(lambda q, v: kinetic(q, v) + math.sin(q[0]), 3), ValueError,
     r"`lagrangian` must be built from CasADi operations.*ca\.sin"),
    ("MechanicalSystem: constraints as a nested list",
     lambda c: dmoc.MechanicalSystem(kinetic, 3, constraints=lambda q: [[-ca.sin(q[2]), ca.cos(q[2]), 0]]),
     ValueError, r"`constraints` must return a CasADi expression; got a list.*ca\.horzcat"),
    ("knife_edge(mass=-1)", lambda c: knife_edge(mass=-1), ValueError,
     "`mass` must be finite and positive"),
    ("OptimalControlProblem: q_goal of shape (1, 3)", lambda c: problem(c, q_goal=[[0.0, 1.0, 0.0]]),
     ValueError, r"`q_goal` must have shape \(3,\)"),
    ("OptimalControlProblem: q_start=None", lambda c: problem(c, q_start=None), ValueError,
     "`q_start` is required"),
    ("OptimalControlProblem: sideways v_goal", lambda c: problem(c, v_goal=[0.0, 1.0, 0.0]),
     ValueError, "`v_goal` violates the velocity constraints"),
    ("OptimalControlProblem: NaN in q_goal", lambda c: problem(c, q_goal=[0.0, np.nan, 0.0]),
     ValueError, "`q_goal` entry 1 is NaN"),
    ("OptimalControlProblem: True in q_goal", lambda c: problem(c, q_goal=[0.0, True, 0.0]),
     TypeError, "`q_goal` must hold real numbers or None; entry 1 is True"),
    ('OptimalControlProblem: "0.5" in v_start', lambda c: problem(c, v_start=[0.0, "0.5", 0.0]),
     TypeError, "`v_start` must hold real numbers or None; entry 1 is '0.5'"),
    ("OptimalControlProblem: NaN in control_bounds",
     lambda c: problem(c, control_bounds=([np.nan, 0.0], [1.0, 1.0])), ValueError,
     "`control_bounds` entry 0 is NaN"),
    ("OptimalControlProblem: True in control_bounds",
     lambda c: problem(c, control_bounds=([True, 0.0], [1.0, 1.0])), TypeError,
     "`control_bounds` must hold real numbers or None; entry 0 is True"),
    ("optimize: unknown IPOPT option tolerance",
     lambda c: dmoc.optimize(problem(c), options={"tolerance": 1e-9}), ValueError,
     "(?s)`options`.*No such IPOPT option: tolerance"),
    ("optimize: a list for guess", lambda c: dmoc.optimize(problem(c), guess=[1, 2]), TypeError,
     "`guess` must be a Trajectory"),
    ('optimize: options={"max_iter": 3.7}',
     lambda c: dmoc.optimize(problem(c), options={"max_iter": 3.7}), ValueError,
     r"`options\['max_iter'\]` must be an integer .*got 3.7"),
    ('optimize: check="yes"', lambda c: dmoc.optimize(problem(c), check="yes"), TypeError,
     "`check` must be True or False; got 'yes'"),
    ('optimize: options={"max_iter": True}',
     lambda c: dmoc.optimize(problem(c), options={"max_iter": True}), TypeError,
     r"`options\['max_iter'\]` must be an integer, not a bool"),
    ("OptimalControlProblem: path constraint q[0] < 0.5",
     lambda c: problem(c, path_constraints=lambda q, v, u: q[0] < 0.5), ValueError,
     r"`path_constraints` must return expressions g imposed as g <= 0, not comparisons"),
    ("OptimalControlProblem: q_goal inside a keep-out disc",
     lambda c: problem(c, path_constraints=lambda q, v, u: 0.25 - ca.sumsqr(q[:2] - ca.DM([0, 1]))),
     ValueError, r"`q_goal` must satisfy `path_constraints` g <= 0, .*got g\[0\] = 0.25 there"),
    ("Trajectory: t not the grid of h", lambda c: trajectory(t=[0.0, 1.0, 2.0]), ValueError,
     "`t` must be the grid"),
    ("Trajectory: complex q", lambda c: trajectory(q=[[0.0], [1.0 + 1e-3j], [2.0]]), TypeError,
     "`q` .*complex"),
    ("Trajectory: strings in q", lambda c: trajectory(q=[["a"], ["b"], ["c"]]), TypeError,
     "`q` must be an array of real numbers"),
    ("Trajectory: ragged q", lambda c: trajectory(q=[[0.0], [1.0, 2.0], [2.0]]), ValueError,
     "`q` .*ragged"),
    ("Trajectory: booleans in lam", lambda c: trajectory(lam=[[True], [False]]), TypeError,
     "`lam` .*bool"),
    ("Trajectory: control_nodes=(0.5, 0.5)",
     lambda c: trajectory(u=[[1.0, 2.0], [2.0, 3.0]], control_nodes=(0.5, 0.5)), ValueError,
     "`control_nodes` must be distinct"),
    ("Trajectory.load: truncated file", lambda c: dmoc.Trajectory.load(c.folder / "trunc.npz"),
     ValueError, "not a valid dmoc trajectory file.*truncated or corrupted"),
    ("Trajectory.load: empty file", lambda c: dmoc.Trajectory.load(c.folder / "empty.npz"),
     ValueError, "not a valid dmoc trajectory file.*it is empty"),
    ("Trajectory.load: random bytes", lambda c: dmoc.Trajectory.load(c.folder / "rand.npz"),
     ValueError, "not a valid dmoc trajectory file.*not an .npz"),
    ("Trajectory.load: an .npz of other arrays", lambda c: dmoc.Trajectory.load(c.folder / "foreign.npz"),
     ValueError, "not a valid dmoc trajectory file.*lacks the fields"),
    ("Trajectory.control past the horizon", lambda c: c.traj.control(c.traj.t[-1] + 1), ValueError,
     r"`t` must lie in the horizon \[t_0, t_N\] = \[0.0, 0.4\]"),
    ('Trajectory.control("abc")', lambda c: c.traj.control("abc"), TypeError,
     "`t` must be a time or a 1-D array of times; got str"),
    ("Trajectory.save to a folder", lambda c: c.traj.save(c.folder), ValueError,
     "`path` must be a file name; got the folder"),
    ("Trajectory.save into a missing folder", lambda c: c.traj.save(c.folder / "no" / "run.npz"),
     ValueError, "the folder of `path` must be an existing folder; .*no' does not exist"),
    ("Trajectory.load of a folder", lambda c: dmoc.Trajectory.load(c.folder), ValueError,
     "`path` must be a file; got the folder"),
    ("Trajectory.load: missing file", lambda c: dmoc.Trajectory.load(c.folder / "nothing.npz"),
     FileNotFoundError, "`path` must be an existing file; there is no file .*nothing.npz"),
    ("OptimizationResult.load of a trajectory file",
     lambda c: dmoc.OptimizationResult.load(c.folder / "good.npz"), ValueError,
     "not an optimization result file.*lacks the fields.*it is a trajectory file"),
    ("OptimizationResult.load: random bytes", lambda c: dmoc.OptimizationResult.load(c.folder / "rand.npz"),
     ValueError, "not an optimization result file.*not an .npz"),
    ("OptimizationResult.load of an .npy", lambda c: dmoc.OptimizationResult.load(c.folder / "one.npy"),
     ValueError, "not an optimization result file.*it is an .npy file"),
    ("OptimizationResult.load: empty file", lambda c: dmoc.OptimizationResult.load(c.folder / "empty.npz"),
     ValueError, "not an optimization result file.*it is empty"),
    ('optimize: linear_solver "ma57" (not installed)',
     lambda c: dmoc.optimize(problem(c), options={"linear_solver": "ma57"}), ValueError,
     "`options\\['linear_solver'\\]` = 'ma57' is not available in this IPOPT build, which "
     "has 'mumps'"),
    ("optimize: max_iter 2**32 + 3", lambda c: dmoc.optimize(problem(c), options={"max_iter": 2**32 + 3}),
     ValueError, r"`options\['max_iter'\]` must be an integer from -2147483648 to 2147483647"),
    ("optimize: max_iter 1e30", lambda c: dmoc.optimize(problem(c), options={"max_iter": 1e30}),
     ValueError, r"`options\['max_iter'\]` must be an integer from"),
    ("optimize: tol nan", lambda c: dmoc.optimize(problem(c), options={"tol": float("nan")}),
     ValueError, r"`options\['tol'\]` must be finite; got nan"),
    ('save_trajectory_plots: name="sub/run"',
     lambda c: plotting.save_trajectory_plots(c.traj, c.folder, "sub/run"), ValueError,
     "`name` must be a file-name prefix without a path separator; got 'sub/run'"),
    ("save_trajectory_plots: out a file",
     lambda c: plotting.save_trajectory_plots(c.traj, c.folder / "plain", "run"), ValueError,
     "`out` must be a folder .*plain', which is a file"),
    ("simulate: steps=10**10", lambda c: simulate(c, steps=10 ** 10), ValueError,
     r"`steps` = 10000000000 needs at least .* bytes"),
    ("simulate: tol=1e-300", lambda c: simulate(c, tol=1e-300), dmoc.SolverError,
     "`tol` = 1.0e-300 is below the round-off floor"),
    ('dirac_differential(disc, "plus")', lambda c: dmoc.dirac.dirac_differential(c.disc, "plus"),
     ValueError, r"`variant` must be one of '\+', '-'; got 'plus'"),
    ('action_sum(disc, "x", ...)',
     lambda c: dmoc.action_sum(c.disc, "x", *[ca.SX.sym(s, 3, 3) for s in ("q", "a", "p", "s")], 0.1),
     ValueError, r"`variant` must be one of '\+', '-'; got 'x'"),
    ('dirac_differential("disc", "+")', lambda c: dmoc.dirac.dirac_differential("disc", "+"),
     TypeError, "`disc` must be a Discretization; got str"),
    ('replay_error("problem", None)', lambda c: diagnostics.replay_error("problem", None), TypeError,
     "`problem` must be an OptimalControlProblem"),
    ("dirac_defect(..., tol_rank=-1)", lambda c: dmoc.dirac.dirac_defect(c.disc, c.traj, tol_rank=-1.0),
     ValueError, "`tol_rank` must be finite and positive"),
    ("residual_norms of a trajectory without multipliers",
     lambda c: diagnostics.residual_norms(c.disc, free_multipliers()), ValueError, "`traj.lam`"),
    ('optimize_many(options={"max_iter": None})',
     lambda c: batch.optimize_many([problem(c)], options={"max_iter": None}, client=UNREACHABLE),
     TypeError, r"`options\['max_iter'\]` must be a number"),
    ("optimize_many(options={3: 1})",
     lambda c: batch.optimize_many([problem(c)], options={3: 1}, client=UNREACHABLE), TypeError,
     "`options` must have string keys"),
    ("simulate_many: run with key tolerance",
     lambda c: batch.simulate_many(c.disc, [{"q0": START, "v0": [1, 0, 0], "steps": 2, "tolerance": 1e-9}],
                                   client=UNREACHABLE), ValueError,
     r"`runs\[0\]` has unknown keys \['tolerance'\]"),
    ('batch.Cluster("tcp://127.0.0.1:1", workers=2)',
     lambda c: batch.Cluster(UNREACHABLE, workers=2), ValueError,
     "`workers` starts a LocalCluster; it cannot go with an `address`"),
    ("batch.Cluster(workers=0)", lambda c: batch.Cluster(workers=0), ValueError,
     "`workers` must be a positive integer; got 0"),
    ('optimize_many(client="", "inproc://x")',
     lambda c: [batch.optimize_many([problem(c)], client=address) for address in ("inproc://x", "")],
     ValueError, "`client` must be a scheduler address such as 'tcp://host:8786'"),
    ('optimize_many(client="tls://...") without certificates',
     lambda c: batch.optimize_many([problem(c)], client="tls://127.0.0.1:1", connect_timeout=1),
     ValueError, "`client`='tls://127.0.0.1:1' needs TLS certificates"),
    ("optimize_many(client=closed_client)",
     lambda c: batch.optimize_many([problem(c)], client=closed_client()), ValueError,
     "`client` is a distributed.Client that is closed"),
    ("simulate_many(disc, runs=[{}])", lambda c: batch.simulate_many(c.disc, [{}], client=UNREACHABLE),
     ValueError, r"`runs\[0\]` must give `q0` and `steps` of `simulate`; it lacks `q0` and `steps`"),
    ('batch.Cluster(security="tls")', lambda c: batch.Cluster(security="tls"), TypeError,
     "`security` must be a distributed.Security"),
    ("OptimalControlProblem: parameters=[1.0]", lambda c: problem(c, parameters=[1.0]), TypeError,
     "`parameters` must be a dict"),
    ('parameters={"2r": 1.0}',
     lambda c: problem(c, parameters={"2r": 1.0}, running_cost=lambda q, v, u, w: ca.sumsqr(u)),
     ValueError, "`parameters` names must be identifiers"),
    ('parameters={"r": nan}',
     lambda c: problem(c, parameters={"r": np.nan}, running_cost=lambda q, v, u, w: ca.sumsqr(u)),
     ValueError, r"`parameters\['r'\]` must be finite"),
    ("parameters given, running_cost=lambda q, v, u: ...",
     lambda c: problem(c, parameters={"r": 1.0}, running_cost=lambda q, v, u: ca.sumsqr(u)),
     TypeError, "`running_cost` must take .* with `parameters`"),
    ("with_parameters(weight=1.0) on a problem with only r",
     lambda c: parametric(c).with_parameters(weight=1.0), ValueError,
     r"`parameters` has unknown keys \['weight'\]"),
    ("with_parameters(r=1.0) on a problem without parameters",
     lambda c: problem(c).with_parameters(r=1.0), ValueError, "this problem has no parameters"),
    ("disc.discrete_cost(3)", lambda c: c.disc.discrete_cost(3), TypeError,
     "`running_cost` must be a callable"),
    ('parameters={"r": np.zeros((5, 1))} for N = 12',
     lambda c: problem(c, parameters={"r": np.zeros((3, 1))}, running_cost=lambda q, v, u, w: ca.sumsqr(u)),
     ValueError, r"`parameters\['r'\]` must be a scalar or shape \(k,\) \(fixed\), \(N, k\) = \(5, k\)"),
    ("with_parameters(t=[0.0, 1.0])",
     lambda c: problem(c, parameters={"t": 0.0}, running_cost=lambda q, v, u, w: ca.sumsqr(u)).with_parameters(
         t=[0.0, 1.0]), ValueError, r"`parameters\['t'\]` must be a scalar \(the start time"),
    ('dmoc.MPC(problem, references={"r": ...}) with r fixed',
     lambda c: dmoc.MPC(parametric(c), references={"r": np.ones((3, 1))}), ValueError,
     "`references` names parameters given per step or per knot of `problem`, \\[\\]; got 'r'"),
    ("dmoc.tvlqr(disc, traj, Q, np.zeros((2, 2)))",
     lambda c: dmoc.tvlqr(c.disc, solved(c).trajectory, np.eye(6), np.zeros((2, 2))), ValueError,
     "`R` must be positive definite"),
    ("dmoc.flow_jacobians(disc, traj) of a (-) run",
     lambda c: dmoc.flow_jacobians(c.disc, dmoc.optimize(problem(c, variant="-"), check=False).trajectory),
     ValueError, r"`trajectory` must be of the \(\+\) form"),
    ('MechanicalSystem: units={"q": ("m",)} for n = 3',
     lambda c: dmoc.MechanicalSystem(lambda q, v: ca.dot(v, v) / 2, 3, units={"q": ("m",)}),
     ValueError, r"`units\['q'\]` must be 3 one-line strings, one unit for each of the 3 coordinates"),
    ("plot_path: obstacles of shape (2,)", lambda c: plotting.plot_path(c.traj, obstacles=[1.0, 2.0]),
     ValueError, r"`obstacles` must be discs \(x, y, radius\), shape \(K, 3\), or a callable g\(x, y\)"),
    ("plot_controls: bounds of shape (3,) for n_u = 2",
     lambda c: plotting.plot_controls(c.traj, bounds=([0, 0, 0], [1, 1, 1])), ValueError,
     r"`bounds` must be a pair \(lower, upper\) of arrays of shape \(2,\)"),
    ("plot_path: bodies=one Body, not a tuple", lambda c: plotting.plot_path(
        c.traj, bodies=dmoc.Body("a", lambda q: q[None, :2])), TypeError, "`bodies` must be a list or tuple"),
    ("Body: outline a list of points", lambda c: dmoc.Body("box", [[0, 0]]), TypeError,
     "`outline` of Body 'box' must be a callable"),
    ("MechanicalSystem: one control name for n_u = 2", lambda c: dmoc.MechanicalSystem(
        lambda q, v: v[0] ** 2, 1, n_u=2, control_names=("f",)), ValueError,
     "`control_names` must be 2 strings"),
    ("Trajectory.sample past the horizon", lambda c: c.traj.sample(c.traj.t[-1] + 1), ValueError,
     r"`t` must lie in the horizon \[t_0, t_N\] = \[0.0, 0.4\]; .* \(the solution is not extrapolated\)"),
    ("OptimalControlProblem: v_start and p_start both given",
     lambda c: problem(c, v_start=[0, 0, 0], p_start=[0, 0, 0]), ValueError,
     "give the start as `v_start` or as `p_start`, not both"),
    ("from_waypoints: times not ending at the horizon",
     lambda c: dmoc.from_waypoints(c.disc, [START, GOAL], [0.0, 0.9], steps=10), ValueError,
     r"`times` must increase from 0 to the horizon N h = 1.0"),
    ("MPC.step(q) without v or p", lambda c: dmoc.MPC(problem(c)).step(START), ValueError,
     "give the measured state as `v` or as `p`, exactly one"),
    ("MPC.step(q, p=p) with a NaN entry of q", lambda c: _stepped(dmoc.MPC(problem(c))).step(
        [0.0, np.nan, 0.0], p=START), ValueError, r"MPC step 1: `q` must be finite; entry \(1,\) is nan"),
    ("MPC(problem, measurement='refuse').step(q, v=v) with q above a bound",
     lambda c: _stepped(dmoc.MPC(problem(c, state_bounds=([-1] * 3, [1] * 3)), measurement="refuse")).step(
         [0.0, 1.002, 0.0], v=START), ValueError,
     r"MPC step 1: .*q\[1\] \(y\) = 1.002 > its upper bound 1\b"),
    ("MPC(problem, measurement='clip')", lambda c: dmoc.MPC(problem(c), measurement="clip"), ValueError,
     "`measurement` must be one of 'project', 'refuse'; got 'clip'"),
    ("MPC(group_problem).step((R, x), v=v) with a NaN in R",
     lambda c: _rolled(dmoc.MPC(sphere_roll())).step((_nan_rotation(), [0.0, 0.0]), v=[0.0] * 5),
     ValueError, r"MPC step 1: `q\[0\] \(R\)` must be finite; entry \(1, 2\) is nan"),
    ("MPC(group_problem, measurement='refuse').step((R, x), v=v) with R off SO(3)",
     lambda c: dmoc.MPC(sphere_roll(), measurement="refuse").step((np.diag([1.001, 1.0, 1.0]), [0.0, 0.0]),
                                                                   v=[0.0] * 5),
     ValueError, r"MPC step 0: .*rotation: \|R\^T R - I\| = 2\.001e-03"),
    ("MPC(group_problem, guess=...)", lambda c: dmoc.MPC(sphere_roll(), guess=c.traj), ValueError,
     "`guess` is not taken by MPC of a GroupOptimalControlProblem"),
    ("optimize_to_accuracy(problem, 0.0)", lambda c: optimize_to_accuracy(problem(c), 0.0), ValueError,
     "`accuracy` must be finite and positive"),
    ("optimize_to_accuracy(problem, 1.5)", lambda c: optimize_to_accuracy(problem(c), 1.5), ValueError,
     r"`accuracy` must be a relative error in \[1e-09, 1\)"),
    ("estimate_error(problem, result) with result of another N",
     lambda c: estimate_error(problem(c, steps=20), solved(c)), ValueError,
     r"`result` must be an optimum of `problem` \(20 steps\); got one on 5 steps"),
    ("estimate_error(problem, result, reference=result)",
     lambda c: estimate_error(problem(c), solved(c), reference=solved(c)), ValueError,
     "`reference` must be an optimum on another number of steps"),
    ("problem.with_steps(0)", lambda c: problem(c).with_steps(0), ValueError,
     "`steps` must be a positive integer; got 0"),
]

# Rows of the command-line table whose bad value reaches an API call: (id, the call the
# command line makes with that value, built-in class, words).
CLI_ROWS = [
    ("dmoc optimize knife-edge --steps 0", lambda c: problem(c, steps=0), ValueError,
     "`steps` must be a positive integer"),
    ("dmoc optimize knife-edge --duration -1", lambda c: dmoc.discretize(knife_edge(), -1 / 40),
     ValueError, "`h` must be finite and positive"),
    ("dmoc optimize knife-edge --goal 1,2", lambda c: problem(c, q_goal=[1.0, 2.0]), ValueError,
     r"`q_goal` must have shape \(3,\)"),
    ("dmoc optimize knife-edge --goal 1,2,x", lambda c: problem(c, q_goal=[1.0, 2.0, "x"]),
     TypeError, "`q_goal` must hold real numbers or None"),
    ("dmoc optimize knife-edge --rule simpson", lambda c: dmoc.discretize(knife_edge(), 0.1, "simpson"),
     ValueError, "`rule` must be one of"),
    ("dmoc optimize knife-edge --variant 0", lambda c: problem(c, variant="0"), ValueError,
     r"`variant` must be one of '\+', '-'"),
    ("dmoc optimize knife-edge --param mass=-1", lambda c: knife_edge(mass=-1.0), ValueError,
     "`mass` must be finite and positive"),
    ("dmoc simulate knife-edge --velocity 0,1,0", lambda c: simulate(c, q0=START, v0=[0.0, 1.0, 0.0]),
     ValueError, "`v0` violates the velocity constraints"),
    ("dmoc simulate knife-edge --start 0,free,0", lambda c: simulate(c, q0=[0.0, None, 0.0]),
     TypeError, "`q0` must be an array of real numbers"),
    ("dmoc simulate knife-edge --controls u3.npy", lambda c: simulate(c, controls=np.zeros((5, 3))),
     ValueError, r"`controls` must have shape \(5, 2\)"),
    ("dmoc simulate factories.py:lc --rule trapezoid",
     lambda c: dmoc.simulate(dmoc.discretize(dmoc.systems.lc_circuit(), 0.1, "trapezoid"),
                             q0=[0.0, 1.0, 1.0], v0=[0.0, 0.0, 0.0], steps=2), ValueError,
     "`rule` 'trapezoid' gives no one-step map"),
    ("dmoc simulate knife-edge --steps 1e3", lambda c: simulate(c, steps=1e3), ValueError,
     "`steps` must be a positive integer"),
    ("dmoc simulate knife-edge --param mass=nan", lambda c: knife_edge(mass=np.nan), ValueError,
     "`mass` must be finite and positive"),
    ("dmoc simulate knife-edge --start 0,0,inf", lambda c: simulate(c, q0=[0.0, 0.0, np.inf]),
     ValueError, "`q0` must be finite"),
    ("dmoc optimize knife-edge --control-min 1,none --control-max 0,none",
     lambda c: problem(c, control_bounds=([1.0, None], [0.0, None])), ValueError,
     "`control_bounds` must satisfy lower <= upper"),
]

# Plain bad input at the entry points outside the tables: (id, call, built-in class, words).
ENTRY_POINTS = [
    ("simulate(None, ...)", lambda c: dmoc.simulate(None, q0=Q0, v0=V0, steps=5), TypeError,
     "`disc` must be a Discretization; got NoneType"),
    ("OptimalControlProblem(None, ...)", lambda c: dmoc.OptimalControlProblem(None, 5, q_start=START, q_goal=GOAL),
     TypeError, "`disc` must be a Discretization; got NoneType"),
    ("OptimalControlProblem: q_goal=None", lambda c: problem(c, q_goal=None), ValueError,
     "`q_goal` is required"),
    ("optimize(None)", lambda c: dmoc.optimize(None), TypeError,
     "`problem` must be an OptimalControlProblem; got NoneType"),
    ("step_residual(None)", lambda c: dmoc.step_residual(None), TypeError,
     "`disc` must be a Discretization"),
    ("StepResidual(None)", lambda c: dmoc.StepResidual(None), TypeError, "`disc` must be a Discretization"),
    ("Trajectory.load(None)", lambda c: dmoc.Trajectory.load(None), TypeError,
     r"`path` must be a path \(str or os.PathLike\); got NoneType"),
    ("Trajectory.save(None)", lambda c: c.traj.save(None), TypeError, "`path` must be a path"),
    ("dirac_defect(disc, None)", lambda c: dmoc.dirac.dirac_defect(c.disc, None), TypeError,
     "`traj` must be a Trajectory"),
    ("optimization_summary(None, None)", lambda c: diagnostics.optimization_summary(None, None),
     TypeError, "`problem` must be an OptimalControlProblem"),
    ("plot_path(None)", lambda c: plotting.plot_path(None), TypeError, "`traj` must be a Trajectory"),
    ("plot_path: x=7 for n = 3", lambda c: plotting.plot_path(c.traj, x=7), ValueError,
     r"`x` must be a column of q, an integer in \[0, 3\); got 7"),
    ('plot_path: heading="theta"', lambda c: plotting.plot_path(c.traj, heading="theta"), ValueError,
     "`heading` must be a column of q"),
    ('plot_path: goal="abc"', lambda c: plotting.plot_path(c.traj, goal="abc"), TypeError,
     "`goal` must be an array of real numbers"),
    ("plot_path: one label", lambda c: plotting.plot_path(c.traj, labels=("x",)), ValueError,
     "`labels` must be 2 strings"),
    ("plot_states: 1 name for n = 3", lambda c: plotting.plot_states(c.traj, names=["a"]), ValueError,
     "`names` must be 3 strings"),
    ("plot_controls(None)", lambda c: plotting.plot_controls(None), TypeError,
     "`traj` must be a Trajectory"),
    ('plot_controls: names="abc" (a string)', lambda c: plotting.plot_controls(c.traj, names="abc"),
     TypeError, "`names` must be a sequence of 2 strings"),
    ("plot_convergence: 2 step sizes, 1 error", lambda c: plotting.plot_convergence([0.1, 0.05], [1.0]),
     ValueError, r"`errors` must have shape \(2,\)"),
    ('plot_convergence: h="a"', lambda c: plotting.plot_convergence("a", [1.0]), TypeError,
     "`h` must be a 1-D array of real numbers"),
    ('plot_convergence: order="x"', lambda c: plotting.plot_convergence([0.1, 0.05], [1.0, 0.25], order="x"),
     TypeError, "`order` must be a real number"),
    ("plot_cost_convergence: 3 step counts, 1 cost",
     lambda c: plotting.plot_cost_convergence([10, 20, 40], [1.0]), ValueError,
     r"`costs` must have shape \(3,\)"),
    ("save_trajectory_plots(None, ...)", lambda c: plotting.save_trajectory_plots(None, c.folder, "a"),
     TypeError, "`traj` must be a Trajectory"),
    ("save_trajectory_plots: out=None", lambda c: plotting.save_trajectory_plots(c.traj, None, "a"),
     TypeError, "`out` must be a path"),
    ("save_trajectory_plots: disc=3", lambda c: plotting.save_trajectory_plots(c.traj, c.folder, "a", disc=3),
     TypeError, "`disc` must be a Discretization or None"),
    ("animate(None, ...)", lambda c: animation.animate(None, c.folder / "a.gif"), TypeError,
     "`traj` must be a Trajectory"),
    ("animate: path=None", lambda c: animation.animate(c.traj, None), TypeError, "`path` must be a path"),
    ("animate: x=9 for n = 3", lambda c: animation.animate(c.traj, c.folder / "a.gif", x=9), ValueError,
     "`x` must be a column of q"),
    ("animate: fps=-1", lambda c: animation.animate(c.traj, c.folder / "a.gif", fps=-1), ValueError,
     "`fps` must be finite and positive"),
]


@pytest.mark.parametrize("call, builtin, words", [row[1:] for row in API_ROWS + CLI_ROWS],
                         ids=[row[0] for row in API_ROWS + CLI_ROWS])
def test_every_bad_input_of_the_table_is_a_dmoc_error(ctx, call, builtin, words):
    assert_dmoc_error(ctx, call, builtin, words)


@pytest.mark.parametrize("call, builtin, words", [row[1:] for row in ENTRY_POINTS],
                         ids=[row[0] for row in ENTRY_POINTS])
def test_plain_bad_input_at_an_entry_point_is_a_dmoc_error(ctx, call, builtin, words):
    assert_dmoc_error(ctx, call, builtin, words)
    assert not (ctx.folder / "a.gif").exists()          # refused before anything is written


def assert_dmoc_error(ctx, call, builtin, words):
    """`call(ctx)` raises a DmocError that is also `builtin`, its message matching `words`."""
    with pytest.raises(Exception, match=words) as info:
        call(ctx)
    assert isinstance(info.value, dmoc.DmocError), type(info.value).__mro__
    assert isinstance(info.value, builtin), type(info.value).__mro__


def test_one_case_per_row_of_the_api_table():
    """The API cases above are the rows of docs/verification.md's API table, no more, no
    fewer (a row added there must be added here)."""
    text = (pathlib.Path(__file__).parents[1] / "docs" / "verification.md").read_text()
    table = text.split("## Bad inputs", 1)[1].split("### API", 1)[1].split("###", 1)[0]
    rows = [line for line in table.splitlines() if line.startswith("| ") and "`" in line]
    assert len(rows) == len(API_ROWS), (len(rows), len(API_ROWS))


# ---------------------------------------------------------------------------------------
# The source: no built-in ValueError/TypeError raised outside the validation layer

PACKAGE = pathlib.Path(dmoc.__file__).parent
VALIDATION_LAYER = PACKAGE / "_util" / "checks.py"


def builtin_raises(path):
    """(line, name) of every `raise ValueError(...)` / `raise TypeError(...)` in `path`."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id in ("ValueError", "TypeError"):
                found.append((node.lineno, exc.id))
    return sorted(found)


def test_no_builtin_value_or_type_error_is_raised_outside_the_validation_layer():
    offenders = [f"{path.relative_to(PACKAGE.parent)}:{line}: raise {name}"
                 for path in sorted(PACKAGE.rglob("*.py")) if path != VALIDATION_LAYER
                 for line, name in builtin_raises(path)]
    assert offenders == [], "\n".join(offenders)


def test_the_source_scan_finds_a_builtin_raise(tmp_path):
    """The scan above can fail: it finds both forms, called and bare, and nothing else."""
    sample = tmp_path / "sample.py"
    sample.write_text("def f(x):\n    if x:\n        raise ValueError('x')\n    raise TypeError\n"
                      "def g():\n    raise InputError('fine')\n")
    assert builtin_raises(sample) == [(3, "ValueError"), (4, "TypeError")]
