"""The verdict-quality study of issue 40 (read by benchmarks/verdict.py --study and
tests/results/test_verdict_study.py): seeded random optimal control problems, dmoc's
judged optimum of each, the truth from an independent transcription, and the class of
each verdict.

The problems (`random_problems`): the knife edge, the rolling disk and the car of
`dmoc.systems`, and a Chaplygin sleigh built here (a knife edge whose centre of mass is
off its contact point), all in SI units with random data; rest to rest from the origin to
a random goal, a random horizon and N, rule (midpoint, lobatto3, lobatto4), a free final
time for some, control bounds for some (at 0.8 to 1.4 times the peak of the straight
rest-to-rest motion with a free final time, 1.2 to 1.8 times with a fixed one, 1.5 times
more with a disc, so that they are active for many of those), a keep-out disc beside
the straight path for some.

The truth (`truth`) does not use dmoc's step equations: the continuous Lagrange-d'Alembert
equations are written here from each plant's Lagrangian L, one-forms A(q) and force f
(`Plant`; the built-in systems' data retyped from their docstrings), M(q) q'' = f +
dL/dq - (d/dt dL/dv)_q + A^T lam with A q'' + (dA/dt) q' = 0 solved for q'' and lam
(index 1), and the problem is transcribed by direct multiple shooting: RK4 on N_t
intervals with controls linear between the nodes (bounds at the nodes hold everywhere),
the running cost integrated as a state, path rows at every node, solved by IPOPT through
CasADi. It is solved at N_t = 2 K and K (started from dmoc's optimum resampled, so that
both find the local optimum dmoc claims); J* is the finer one's, its uncertainty the
difference. The replay (`replay`) drives the continuous plant by dmoc's controls
(`Trajectory.control`, each step on its own) from the start with scipy's DOP853.

Classification (`study`): an optimum is *right* when its errors are within what it
declares, DECLARED = 10 times dmoc's own Richardson estimate with its order
(`dmoc.drivers.error_estimate.estimate_error`, ``largest``; CAP = 25 % where that is
infinite, its coarser solve failed) plus three times the truth's uncertainty: the
relative cost error |J_N - J*| / |J*|, the final time's |T_N - T*| / T*, the path rows'
largest value along the replay over their scale max(1, max |g|), and the replay's largest
departure from the knots, each coordinate's over its own excursion, which must also be
below CAP (a motion a quarter of its excursion away is not the motion it claims). A passed verdict on a
right optimum is a true success, on a wrong one a false success; a refusal of a right one
a false refusal, of a wrong one a true refusal. IPOPT's own failures are counted apart (no
optimum to judge), as are truths whose two grids differ by more than TRUTH_SPREAD of J*.
"""

import dataclasses

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

import dmoc
from dmoc.drivers.error_estimate import estimate_error, with_estimate

RULES = ("midpoint", "lobatto3", "lobatto4")
STEPS = {"midpoint": (4, 40), "lobatto3": (3, 30), "lobatto4": (3, 24)}
# a right optimum's errors: within DECLARED times its own estimate; its replay's below CAP
DECLARED, CAP = 10.0, 0.25
TRUTH_INTERVALS = 320
# a truth whose two grids differ by more than this part of J* is not a truth ("truth failed")
TRUTH_SPREAD = 1e-3


@dataclasses.dataclass(frozen=True)
class Plant:
    """A mechanical system written out for the truth: L(q, v), A(q) (m, n), f(q, v, u), as
    CasADi expressions, and `speeds(q, v)`, n - m velocities that span the allowed ones
    (A(q) v = 0): a rest at the goal is imposed on them alone, as the other n rows would be
    dependent on them along the flow, which keeps A v = 0."""
    name: str
    n: int
    lagrangian: object
    constraints: object
    force: object
    speeds: object


def _blade_speeds(q, v):
    """The speed along the heading q[2] and the turning rate."""
    return ca.vertcat(ca.cos(q[2]) * v[0] + ca.sin(q[2]) * v[1], v[2])


def knife_edge_plant(m, J, a):
    """The knife edge on a plane with slope acceleration a (dmoc.systems.knife_edge)."""
    return Plant("knife edge", 3,
                 lambda q, v: m / 2 * (v[0] ** 2 + v[1] ** 2) + J / 2 * v[2] ** 2 - m * a * q[0],
                 lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
                 lambda q, v, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]), _blade_speeds)


def rolling_disk_plant(m, R):
    """The vertical rolling disk, I = m R^2 / 2, J = m R^2 / 4 (dmoc.systems.rolling_disk)."""
    I, J = m * R ** 2 / 2, m * R ** 2 / 4
    return Plant("rolling disk", 4,
                 lambda q, v: m / 2 * (v[0] ** 2 + v[1] ** 2) + I / 2 * v[2] ** 2 + J / 2 * v[3] ** 2,
                 lambda q: ca.vertcat(ca.horzcat(1, 0, -R * ca.cos(q[3]), 0),
                                      ca.horzcat(0, 1, -R * ca.sin(q[3]), 0)),
                 lambda q, v, u: ca.vertcat(0, 0, u[0], u[1]), lambda q, v: v[2:])


def car_plant(m, Iz, Id, l, b):
    """The bicycle car with its centre of mass b ahead of the rear axle (dmoc.systems.car)."""
    def lagrangian(q, v):
        xc, yc = v[0] - b * ca.sin(q[2]) * v[2], v[1] + b * ca.cos(q[2]) * v[2]
        return m / 2 * (xc ** 2 + yc ** 2) + Iz / 2 * v[2] ** 2 + Id / 2 * v[3] ** 2
    return Plant("car", 4, lagrangian,
                 lambda q: ca.vertcat(ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0, 0),
                                      ca.horzcat(-ca.sin(q[2] + q[3]), ca.cos(q[2] + q[3]), l * ca.cos(q[3]), 0)),
                 lambda q, v, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), 0, u[1]),
                 lambda q, v: ca.vertcat(ca.cos(q[2]) * v[0] + ca.sin(q[2]) * v[1], v[3]))


def sleigh_plant(m, Ic, a):
    """The Chaplygin sleigh: contact point (x, y), heading theta, centre of mass a ahead of
    the contact point along the heading, inertia Ic about it; the blade keeps (x, y) from
    slipping sideways; a force F along the heading at the contact point, a torque tau."""
    def lagrangian(q, v):
        xc, yc = v[0] - a * ca.sin(q[2]) * v[2], v[1] + a * ca.cos(q[2]) * v[2]
        return m / 2 * (xc ** 2 + yc ** 2) + Ic / 2 * v[2] ** 2
    return Plant("sleigh", 3, lagrangian,
                 lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
                 lambda q, v, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]), _blade_speeds)


def sleigh_system(plant):
    """The sleigh as a dmoc MechanicalSystem, from the same L, A, f."""
    return dmoc.MechanicalSystem(plant.lagrangian, 3, constraints=plant.constraints, force=plant.force,
                                 n_u=2, names=("x", "y", "theta"))


@dataclasses.dataclass(frozen=True)
class Case:
    """One random problem: its label, the dmoc problem, the plant, the cost's control
    scales, the time weight, the keep-out disc (centre, radius) or None."""
    label: str
    problem: object
    plant: Plant
    scales: tuple
    time_weight: float
    disc: tuple


def random_problems(count, seed=40, only=None):
    """`count` Cases, the i-th of the plants in turn (knife edge, disk, car, sleigh), from
    numpy's generator seeded by `seed`; with `only` (indices), those alone (the others'
    data drawn, their problems not built)."""
    rng = np.random.default_rng(seed)
    cases = [_random_case(i, rng, only is None or i in only) for i in range(count)]
    return [case for case in cases if case is not None]


def _random_case(i, rng, build):
    """Case i of `random_problems` from `rng`, or None when not `build`."""
    kind = ("knife edge", "rolling disk", "car", "sleigh")[i % 4]
    rule = RULES[rng.integers(3)]
    low, high = STEPS[rule]
    steps = int(round(np.exp(rng.uniform(np.log(low), np.log(high)))))
    free, bounded, obstacle = rng.uniform(size=3) < (0.3, 0.35, 0.3)
    D = {"car": rng.uniform(8.0, 25.0)}.get(kind, rng.uniform(1.0, 5.0))
    T = {"car": rng.uniform(5.0, 10.0)}.get(kind, rng.uniform(2.0, 8.0))
    X, Y = D * rng.uniform(0.6, 1.0), D * rng.uniform(-0.4, 0.4)
    heading = rng.uniform(-np.pi / 2, np.pi / 2)
    if kind == "knife edge":
        m, J, incline = rng.uniform(5, 50), rng.uniform(0.5, 5), rng.choice([0.0, rng.uniform(0.0, 0.1)])
        plant, system = knife_edge_plant(m, J, 9.81 * np.sin(incline)), dmoc.systems.knife_edge(m, J, incline)
        goal, scales, state_bounds = [X, Y, heading], (6 * m * D / T ** 2, 6 * J * (abs(heading) + 1) / T ** 2), None
    elif kind == "rolling disk":
        m, R = rng.uniform(1, 20), rng.uniform(0.2, 0.8)
        plant, system = rolling_disk_plant(m, R), dmoc.systems.rolling_disk(m, R)
        goal = [X, Y, None, heading]
        scales, state_bounds = (6 * m * R * D / 2 / T ** 2, 6 * m * R ** 2 / 4 * (abs(heading) + 1) / T ** 2), None
    elif kind == "car":
        m, Iz, Id, l, b = (rng.uniform(800, 2000), rng.uniform(1000, 3000), rng.uniform(0.5, 2.0),
                           rng.uniform(2.4, 3.0), rng.uniform(0.0, 0.5))
        plant, system = car_plant(m, Iz, Id, l, b), dmoc.systems.car(m, Iz, Id, l, b)
        goal, scales = [X, Y, heading, 0.0], (6 * m * D / T ** 2, 6 * Id * 0.6 / T ** 2)
        state_bounds = ([None, None, None, -0.6], [None, None, None, 0.6])
    else:
        m, Ic, a = rng.uniform(10, 60), rng.uniform(0.5, 5), rng.uniform(0.1, 0.5)
        plant = sleigh_plant(m, Ic, a)
        system = sleigh_system(plant)
        goal, scales = [X, Y, heading], (6 * m * D / T ** 2, 6 * (Ic + m * a ** 2) * (abs(heading) + 1) / T ** 2)
        state_bounds = None
    weight = rng.uniform(0.5, 2.0) if free else 0.0
    disc = None
    if obstacle:
        normal = np.array([-Y, X]) / np.hypot(X, Y)
        disc = (np.array([X, Y]) / 2 + rng.choice([-1.0, 1.0]) * 0.12 * D * normal, 0.25 * D)
    # free time stretches to meet tight bounds; a fixed time needs room for the detour
    bound = (rng.uniform(0.8, 1.4) if free else rng.uniform(1.2, 1.8) * (1.5 if disc else 1.0)) if bounded else None
    if not build:
        return None
    n = plant.n
    problem = dmoc.OptimalControlProblem(
        dmoc.discretize(system, T / steps, rule), steps, q_start=np.zeros(n), q_goal=goal,
        running_cost=running_cost(scales, weight),
        control_bounds=None if bound is None else ([-bound * s for s in scales], [bound * s for s in scales]),
        state_bounds=state_bounds, path_constraints=None if disc is None else keep_out(*disc),
        duration=(0.4 * T, 3.0 * T) if free else None)
    label = (f"{i:2d} {kind:<12} {rule:<8} N={steps:<3d}" + (" free-T" if free else "")
             + (f" |u|<={bound:.2f}s" if bound else "") + (" disc" if disc else ""))
    return Case(label, problem, plant, scales, weight, disc)


def running_cost(scales, weight):
    """The running cost (u_0 / s_0)^2 + (u_1 / s_1)^2 + weight, s the `scales`."""
    return lambda q, v, u: (u[0] / scales[0]) ** 2 + (u[1] / scales[1]) ** 2 + weight


def keep_out(centre, radius):
    """The path row r^2 - |(x, y) - c|^2 <= 0 of a keep-out disc of `radius` r at `centre` c."""
    return lambda q, v, u: radius ** 2 - (q[0] - centre[0]) ** 2 - (q[1] - centre[1]) ** 2


def vector_field(plant):
    """The Function (x = (q, v), u) -> x' of `plant`'s Lagrange-d'Alembert equations: q''
    from M q'' + A^T mu = f + dL/dq - (d^2 L / dv dq) v and A q'' = -(dA/dt) v, M the
    Hessian of L in v (mu = -lam)."""
    n = plant.n
    q, v, u = ca.SX.sym("q", n), ca.SX.sym("v", n), ca.SX.sym("u", 2)
    L = plant.lagrangian(q, v)
    M = ca.hessian(L, v)[0]
    A = plant.constraints(q)
    m = A.size1()
    rhs = plant.force(q, v, u) + ca.gradient(L, q) - ca.jacobian(ca.gradient(L, v), q) @ v
    K = ca.blockcat([[M, A.T], [A, ca.SX(m, m)]])
    solution = ca.solve(K, ca.vertcat(rhs, -ca.jacobian(A @ v, q) @ v))
    return ca.Function("field", [ca.vertcat(q, v), u], [ca.vertcat(v, solution[:n])])


def truth(case, guess_traj, intervals=TRUTH_INTERVALS):
    """(J*, T*, uncertainty of J*, success) of `case` by RK4 multiple shooting on
    `intervals` and `intervals` / 2, both started from `guess_traj` resampled."""
    solved = [_shooting(case, guess_traj, K) for K in (intervals // 2, intervals)]
    (J_coarse, _, ok_coarse), (J, T, ok) = solved
    return J, T, abs(J - J_coarse) if ok_coarse else np.inf, ok


def _shooting(case, guess_traj, K):
    """(cost, final time, converged) of the multiple-shooting transcription on K intervals."""
    plant, problem = case.plant, case.problem
    n, field = plant.n, vector_field(plant)
    x, u0, u1, h = ca.SX.sym("x", 2 * n), ca.SX.sym("u0", 2), ca.SX.sym("u1", 2), ca.SX.sym("h")
    cost = running_cost(case.scales, case.time_weight)

    def augmented(x, u):
        return ca.vertcat(field(x, u), cost(x[:n], x[n:], u))
    y = ca.vertcat(x, 0)
    um = (u0 + u1) / 2
    k1 = augmented(y[:2 * n], u0)
    k2 = augmented(y[:2 * n] + h / 2 * k1[:2 * n], um)
    k3 = augmented(y[:2 * n] + h / 2 * k2[:2 * n], um)
    k4 = augmented(y[:2 * n] + h * k3[:2 * n], u1)
    step = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    F = ca.Function("rk4", [x, u0, u1, h], [step[:2 * n], step[2 * n]]).map(K)
    opti = ca.Opti()
    # the controls in units of the cost's scales, so that IPOPT sees numbers of size 1
    X, U_scaled = opti.variable(2 * n, K + 1), opti.variable(2, K + 1)
    U = ca.diag(ca.DM(case.scales)) @ U_scaled
    free = problem.free_time
    T = opti.variable() if free else problem.steps * problem.disc.h
    X_next, dJ = F(X[:, :-1], U[:, :-1], U[:, 1:], T / K)
    opti.subject_to(X[:, 1:] == X_next)
    opti.minimize(ca.sum2(dJ))
    opti.subject_to(X[:, 0] == np.concatenate([problem.q_start, np.zeros(n)]))
    given = np.flatnonzero(np.isfinite(problem.q_goal))
    opti.subject_to(X[given.tolist(), -1] == problem.q_goal[given])
    opti.subject_to(plant.speeds(X[:n, -1], X[n:, -1]) == 0)      # v_goal = 0
    lower, upper = problem.control_bounds
    for i in range(2):
        if np.isfinite(lower[i]):
            opti.subject_to(opti.bounded(lower[i], U[i, :], upper[i]))
    lower, upper = problem.state_bounds
    for i in np.flatnonzero(np.isfinite(lower) | np.isfinite(upper)):
        opti.subject_to(opti.bounded(lower[i], X[int(i), :], upper[i]))
    if case.disc is not None:
        (cx, cy), r = case.disc
        opti.subject_to(r ** 2 - (X[0, :] - cx) ** 2 - (X[1, :] - cy) ** 2 <= 0)
    if free:
        opti.subject_to(opti.bounded(*problem.duration, T))
        opti.set_initial(T, guess_traj.t[-1])
    times = np.linspace(guess_traj.t[0], guess_traj.t[-1], K + 1)
    sample = guess_traj.sample(times)
    opti.set_initial(X, np.vstack([sample.q.T, sample.v.T]))
    opti.set_initial(U_scaled, sample.u.T / np.array(case.scales)[:, None])
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-10,
                                                  "max_iter": 3000})
    try:
        solution = opti.solve()
    except RuntimeError:
        return np.nan, np.nan, False
    return float(solution.value(opti.f)), float(solution.value(T)), True


def replay(case, traj, per_step=20):
    """(largest |q_i(t_k) - q_k,i| over coordinate i's excursion in the optimum, the path
    rows' largest value along the replay over their scale max(1, max |g|) (0 without
    rows)): the continuous plant driven by `traj`'s controls from the start, DOP853 step
    by step (each step's control polynomial on its own). Each coordinate is measured in
    its own units, so that x off by 1.8 m is not measured against the 12 rad a rolling
    disk's rolling angle turns through; a coordinate that moves by no more than sqrt(eps)
    of the largest excursion (one held at rest, moved by round-off) against the largest."""
    n, field = case.plant.n, vector_field(case.plant)
    x = np.concatenate([case.problem.q_start, np.zeros(n)])
    knots, dense = [x[:n]], []
    for k in range(traj.steps):
        t0, t1 = traj.t[k], traj.t[k + 1]
        inside = t1 - 1e-9 * (t1 - t0)

        def rhs(t, x):
            return np.asarray(field(x, traj.control(min(max(t, t0), inside)))).ravel()
        run = solve_ivp(rhs, (t0, t1), x, method="DOP853", rtol=1e-11, atol=1e-12,
                        t_eval=np.linspace(t0, t1, per_step + 1))
        x = run.y[:, -1]
        knots.append(x[:n])
        dense.append(run.y[:n].T)
    excursion = np.ptp(traj.q, axis=0)
    largest = excursion.max()
    scales = np.where(excursion > np.sqrt(np.finfo(float).eps) * largest, excursion, largest)
    departure = float((np.abs(np.array(knots) - traj.q) / scales).max())
    if case.disc is None:
        return departure, 0.0
    (cx, cy), r = case.disc
    points = np.vstack(dense)
    g = r ** 2 - (points[:, 0] - cx) ** 2 - (points[:, 1] - cy) ** 2
    return departure, float(max(g.max(), 0.0) / max(1.0, np.abs(g).max()))


@dataclasses.dataclass
class Row:
    """One problem's figures and class."""
    label: str
    status: str
    verdict_passed: bool
    estimate: float
    cost_error: float
    time_error: float
    departure: float
    path: float
    truth_uncertainty: float
    right: bool
    kind: str
    default_kind: str


def study(case):
    """The Row of `case`: dmoc's judged optimum (`dmoc.optimize`, throw=False), its
    estimate (`estimate_error`; the verdict with it, `with_estimate`, as
    ``optimize(..., estimate=True)`` gives it), the truth, the replay, the class of the
    verdict with the estimate (`kind`) and of the default one without (`default_kind`)."""
    result = dmoc.optimize(case.problem, throw=False)
    status = str(result.status)
    if result.verdict is None:      # IPOPT itself failed: nothing to judge
        return Row(case.label, status, False, *[np.nan] * 6, False, "solver failure", "solver failure")
    traj = result.trajectory
    estimated = estimate_error(case.problem, result)
    judged, estimate = with_estimate(result, estimated), estimated.largest
    J, T, uncertainty, ok = truth(case, traj)
    cost_error = abs(result.cost - J) / abs(J) if ok else np.nan
    time_error = abs(traj.t[-1] - T) / T if ok and case.problem.free_time else 0.0
    departure, path = replay(case, traj)
    ok = ok and uncertainty <= TRUTH_SPREAD * abs(J)
    declared = DECLARED * estimate + 3 * uncertainty / abs(J) + 1e-6 if np.isfinite(estimate) else CAP
    allowed = declared if ok else np.nan
    right = bool(ok and max(cost_error, time_error, path) <= allowed and departure <= min(CAP, allowed))
    return Row(case.label, str(judged.status), judged.success, estimate, cost_error, time_error, departure,
               path, uncertainty / abs(J) if ok else np.nan, right, _kind(ok, judged.success, right),
               _kind(ok, result.success, right))


def _kind(ok, passed, right):
    """The class of a verdict that `passed` (or not) on an optimum that is `right` (or
    not), `ok` whether the truth was found."""
    if not ok:
        return "truth failed"
    return ("true success" if right else "false success") if passed else \
        ("false refusal" if right else "true refusal")


KINDS = ("true success", "false success", "true refusal", "false refusal", "solver failure", "truth failed")


def counts(rows, field="kind"):
    """{kind: count} over KINDS of the rows' `field` ("kind" or "default_kind")."""
    return {kind: sum(getattr(row, field) == kind for row in rows) for kind in KINDS}
