"""Benchmark: the cost of one implicit Dirac step against one explicit RK4 step, on the
inclined knife edge and the vertical rolling disk.

Dirac step: ``dmoc.simulate`` (midpoint rule, variant "+"), three unrolled Newton
iterations on the n + m equations of (37) in the increment q1 - q0 and lam, the residual
max-norm of every step checked, evaluated over the horizon in ``mapaccum`` chunks: "dirac"
is the default path (``jit=None``: the compiled C library, cached on disk by an earlier
run, see dmoc._util.compiled), "dirac-jit" with ``jit=True``, "dirac-vm" the same step
in CasADi's virtual machine (``jit=False``: what runs without a C compiler). Run against an
older checkout (PYTHONPATH), "dirac" is whatever that version's default is. Baselines, each
an SX step Function run with ``mapaccum``: "rk4-ode", classical RK4 on the hand-reduced ODE
(knife edge: x, y, theta, sigma, omega; disk: x, y, theta, phi, Omega, w); "rk4-dae", RK4
on the index-1 Lagrange-d'Alembert DAE built from the same MechanicalSystem (a KKT solve
per stage), what a user with only L, A(q), f writes. h = 0.01, zero controls, 10^4 and 10^5
steps.

Reported per step: evaluation only (for dmoc ``stats["wall_time"]``, the step already
built by a warm-up call; for RK4 the mapaccum call) and total (the whole ``simulate``
call; for RK4 building the mapaccum plus the call). Best of `--repeat` runs. Then, each
in a fresh process: the peak resident memory of a 10^6-step default run, and the first
default run ever of 10^6 steps (an empty cache directory: 0.5 s in the virtual machine,
then compiling, then C). The final-position error against the exact solution is context:
the Dirac step is second order and keeps omega_d = 0; RK4 is fourth order on the ODE, and
on the DAE it drifts off the constraint.

Then the free rigid body on SO(3) (J = diag(1, 2, 3), Omega_0 = (1, 0.3, -0.7)): the group
step of ``dmoc.simulate`` (three Cayley coordinates per step, "group" the default path,
"group-vm" with ``jit=False``) against "rk4-euler", classical RK4 on Euler's equations
(R' = R Omega^, Pi' = Pi x Omega, 12 states) in ``mapaccum``; besides the cost per step, the
energy error, the spatial-angular-momentum error and |R^T R - I| after the run, which RK4
lets drift and the group step keeps at round-off; "se3" the same body in space on SE(3)
(`free_rigid_body(J, mass=1.7)`, its centre of mass from x_0 = (0.4, -1, 2) with
x' = (0.5, -1, 0.2)), its momentum error that of the angular momentum about the origin
x x p_x + R Pi, and the error of its linear momentum p_x.

Then the Chaplygin sphere (J = diag(1, 2, 2.5), m = 1.3, r = 0.7, Omega_0 = (1, -0.5, 2)),
its two forms side by side: "group", `dmoc.systems.chaplygin_sphere` on SO(3) x R^2 (5
increments and 2 rolling multipliers per step), and "embedded", the same ball as a
MechanicalSystem on R^11 (the 9 entries of R and (x, y); L = 1/2 tr(R' J_d R'^T) +
1/2 m |x'|^2, J_d = tr(J)/2 I - J; R^T R = I as 6 holonomic rows, the rolling as 2
one-forms), both with the midpoint rule: the first compile (a fresh process with an empty
cache: the first ``simulate(jit=True)`` of 10 steps, building and compiling the step), a
10^5-step simulation with the compiled step, and after it |R^T R - I| and the drift of the
contact angular momentum K = R J Omega + m r^2 (omega - (e3 . omega) e3) (group: read with
its momenta, R Pi + r e3 x (p_x, 0)).
Then the DMOC of tests/optimize/test_sphere_roll.py on both forms, with body torques (the
embedded force 1/2 R u^ on the entries of R): rest to rest from (I, 0) to a quarter turn
about e3 at (1, 0.5) in 4 s, N = 20, min sum h |u|^2, each built and solved by
``dmoc.optimize`` after ``dmoc.clear_caches`` (wall and CPU seconds, best of `--repeat`, the
forms taking turns); "embedded" from its default guess, "embedded-geo" from the group
form's geodesic guess written entry by entry (the baseline of the printed ratio group /
embedded-geo); their costs differ by the two discretizations' O(h^2) errors. Then the same
build and solve as the first of a fresh process with an empty cache folder (after the
imports), group and embedded-geo, best of `--repeat`.

    python benchmarks/step_cost.py
    python benchmarks/step_cost.py --smallest     # 10^3 steps once, DMOC at N = 4: a smoke run
"""

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.systems import knife_edge, knife_edge_solution, rolling_disk, rolling_disk_solution  # noqa: E402

H = 0.01
INCLINE, GRAVITY = 0.2, 9.81


@dataclass(frozen=True)
class Case:
    """A system, its start, its hand-reduced ODE (z, u) -> z' and the exact solution."""

    system: object            # () -> MechanicalSystem
    q0: tuple
    v0: tuple
    z0: tuple                 # start of the reduced ODE
    reduced: object           # (z, u) -> list of z' entries (CasADi)
    exact: object             # t -> q(t)


def knife_edge_ode(z, u, a=GRAVITY * np.sin(INCLINE)):
    """(x, y, theta, sigma, omega)' with m = J = 1, gravity -a along x."""
    return [z[3] * ca.cos(z[2]), z[3] * ca.sin(z[2]), z[4], u[0] - a * ca.cos(z[2]), u[1]]


def rolling_disk_ode(z, u, roll=1.5, steer=0.25):
    """(x, y, theta, phi, Omega, w)' with m = R = 1, I = 1/2, J = 1/4."""
    return [ca.cos(z[3]) * z[4], ca.sin(z[3]) * z[4], z[4], z[5], u[0] / roll, u[1] / steer]


CASES = {
    "inclined knife edge": Case(
        lambda: knife_edge(incline=INCLINE, gravity=GRAVITY), (0.0, 0.0, 0.0), (1.0, 0.0, 1.0),
        (0.0, 0.0, 0.0, 1.0, 1.0), knife_edge_ode,
        lambda t: knife_edge_solution(t, (0.0, 0.0, 0.0), (1.0, 0.0, 1.0), incline=INCLINE,
                                      gravity=GRAVITY)[0][0]),
    "rolling disk": Case(
        rolling_disk, (0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 1.0, 0.5), (0.0, 0.0, 0.0, 0.0, 1.0, 0.5),
        rolling_disk_ode,
        lambda t: rolling_disk_solution(t, (0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 1.0, 0.5))[0][0]),
}


def rk4(name, f, x, u, h):
    """(x, u, h) -> x_next: one classical RK4 step of x' = f(x, u) (SX)."""
    z = ca.SX.sym("z", x.numel())
    F = ca.Function("f", [z, u], [ca.vertcat(*f(z, u))])
    k1 = F(x, u)
    k2 = F(x + h / 2 * k1, u)
    k3 = F(x + h / 2 * k2, u)
    k4 = F(x + h * k3, u)
    return ca.Function(name, [x, u, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])


def rk4_step(case):
    """RK4 on the hand-reduced ODE of `case`."""
    x, u, h = ca.SX.sym("x", len(case.z0)), ca.SX.sym("u", 2), ca.SX.sym("h")
    return rk4("rk4_step", case.reduced, x, u, h)


def dae_rk4_step(system):
    """RK4 on the Lagrange-d'Alembert DAE of `system` in index-1 form.

    x = (q, v); the acceleration comes from the KKT system
    [M A^T; A 0] [a; -lam] = [f + dL/dq - (d/dq dL/dv) v; -(dA/dq v) v], M = d^2L/dv^2:
    what a user with only L, A(q), f(q, v, u) writes for an explicit integrator.
    """
    n, m = system.n, system.m
    q, v, u = ca.SX.sym("q", n), ca.SX.sym("v", n), ca.SX.sym("u", system.n_u)
    L, A = system.lagrangian(q, v), system.constraint_matrix(q)
    p = ca.gradient(L, v)
    M, C = ca.jacobian(p, v), ca.jacobian(p, q)
    rhs = ca.vertcat(system.force(q, v, u) + ca.gradient(L, q) - ca.mtimes(C, v),
                     -ca.mtimes(ca.jacobian(ca.mtimes(A, v), q), v))
    acc = ca.solve(ca.blockcat([[M, A.T], [A, ca.SX.zeros(m, m)]]), rhs)[:n]
    state = ca.Function("qv", [q, v, u], [ca.vertcat(v, acc)])
    x = ca.SX.sym("x", 2 * n)
    return rk4("dae_rk4_step", lambda z, w: ca.vertsplit(state(z[:n], z[n:], w)), x, u, ca.SX.sym("h"))


def time_dirac(disc, case, steps, **jit):
    """(evaluation seconds, total seconds, final q, max residual, native) of one simulate."""
    tic = time.perf_counter()
    res = dmoc.simulate(disc, q0=case.q0, v0=case.v0, steps=steps, **jit)
    total = time.perf_counter() - tic
    if not res.success:
        raise RuntimeError(res.message)
    return (res.stats["wall_time"], total, res.trajectory.q[-1], res.stats["max_residual"],
            res.stats.get("native", jit.get("jit", False)))


def time_mapaccum(step, x0, steps, n):
    """(evaluation seconds, total seconds, final q, nan, False) of a step Function over `steps`."""
    tic = time.perf_counter()
    horizon = step.mapaccum("horizon", steps)
    built = time.perf_counter()
    X = horizon(x0, np.zeros((2, steps)), H)
    done = time.perf_counter()
    return done - built, done - tic, np.array(X[:n, -1]).ravel(), float("nan"), False


def methods(case):
    disc, system = dmoc.discretize(case.system(), H), case.system()
    n, rk, dae = system.n, rk4_step(case), dae_rk4_step(system)
    return {
        "dirac": lambda steps: time_dirac(disc, case, steps),
        "dirac-jit": lambda steps: time_dirac(disc, case, steps, jit=True),
        "dirac-vm": lambda steps: time_dirac(disc, case, steps, jit=False),
        "rk4-ode": lambda steps: time_mapaccum(rk, np.array(case.z0), steps, n),
        "rk4-dae": lambda steps: time_mapaccum(dae, np.concatenate([case.q0, case.v0]), steps, n),
    }


def best(repeat, fun, steps):
    runs = [fun(steps) for _ in range(repeat)]
    return (min(r[0] for r in runs), min(r[1] for r in runs)) + runs[-1][2:]


def fresh_process(*args, env=None):
    """Run this script with `args` in a new process; its stdout."""
    return subprocess.run([sys.executable, __file__, *args], check=True, capture_output=True,
                          text=True, env={**os.environ, **(env or {})}).stdout.strip()


def one_run(name, steps):
    """(this process) `steps` default steps of case `name`: wall seconds, peak RSS MB, native."""
    case = CASES[name]
    disc = dmoc.discretize(case.system(), H)
    tic = time.perf_counter()
    res = dmoc.simulate(disc, q0=case.q0, v0=case.v0, steps=steps)
    wall = time.perf_counter() - tic
    with open("/proc/self/status") as status:      # VmHWM: this process's peak RSS (Linux)
        peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM")) / 1024
    print(f"{wall:.4f} {peak:.1f} {res.stats.get('native', False)} {res.stats['max_residual']:.2e}")


RIGID_INERTIA, RIGID_OMEGA = np.array([1.0, 2.0, 3.0]), np.array([1.0, 0.3, -0.7])
RIGID_MASS, RIGID_X0, RIGID_V0 = 1.7, np.array([0.4, -1.0, 2.0]), np.array([0.5, -1.0, 0.2])


def rk4_euler_step():
    """RK4 on Euler's equations of the free body, state (rows of R, Pi)."""
    def euler(z, u):
        R, Pi = ca.reshape(z[:9], 3, 3).T, z[9:]
        omega = Pi / RIGID_INERTIA
        Rdot = ca.mtimes(R, dmoc.mechanics.rotations.hat(omega))
        return ca.vertsplit(ca.vertcat(ca.vec(Rdot.T), ca.cross(Pi, omega)))
    x, u, h = ca.SX.sym("x", 12), ca.SX.sym("u", 2), ca.SX.sym("h")
    return rk4("rk4_euler_step", euler, x, u, h)


def rigid_errors(R, Pi):
    """(energy error, spatial momentum error, |R^T R - I|) of the end state (R, Pi)."""
    Pi0 = RIGID_INERTIA * RIGID_OMEGA
    energy = lambda P: 0.5 * P @ (P / RIGID_INERTIA)  # noqa: E731
    return (abs(energy(Pi) - energy(Pi0)), np.abs(R @ Pi - Pi0).max(),
            np.abs(R.T @ R - np.eye(3)).max())


def time_group(disc, steps, **jit):
    """(evaluation seconds, total seconds, errors) of one simulate of the free body."""
    tic = time.perf_counter()
    res = dmoc.simulate(disc, q0=np.eye(3), v0=RIGID_OMEGA, steps=steps, **jit)
    total = time.perf_counter() - tic
    return res.stats["wall_time"], total, rigid_errors(res.trajectory.R[-1], res.trajectory.Pi[-1])


def time_in_space(disc, steps):
    """(evaluation seconds, total seconds, errors) of one simulate of the free body in space
    (SE(3), x its centre of mass, from RIGID_X0 with RIGID_V0); the errors are those of its
    energy, of its angular momentum about the origin x x p_x + R Pi, |R^T R - I|, and of its
    linear momentum p_x, at the end."""
    tic = time.perf_counter()
    res = dmoc.simulate(disc, q0=(np.eye(3), RIGID_X0), v0=np.r_[RIGID_OMEGA, RIGID_V0],
                        steps=steps)
    total, traj = time.perf_counter() - tic, res.trajectory
    m = disc.system.mass_matrix[0, 0]

    def energy(k):
        return 0.5 * traj.Pi[k] @ (traj.Pi[k] / RIGID_INERTIA) + 0.5 * traj.p_x[k] @ traj.p_x[k] / m
    L = np.cross(traj.x[[0, -1]], traj.p_x[[0, -1]]) + traj.spatial_momentum[[0, -1]]
    return res.stats["wall_time"], total, (abs(energy(-1) - energy(0)), np.abs(L[1] - L[0]).max(),
                                           traj.orthogonality_defect[-1],
                                           np.abs(traj.p_x[-1] - traj.p_x[0]).max())


def time_rk4_euler(step, steps):
    """(evaluation seconds, total seconds, errors) of RK4 on Euler's equations."""
    tic = time.perf_counter()
    horizon = step.mapaccum("horizon", steps)
    built = time.perf_counter()
    X = np.array(horizon(np.concatenate([np.eye(3).ravel(), RIGID_INERTIA * RIGID_OMEGA]),
                         np.zeros((2, steps)), H))[:, -1]
    done = time.perf_counter()
    return done - built, done - tic, rigid_errors(X[:9].reshape(3, 3), X[9:])


def rigid_body_table(repeat, horizons):
    disc, rk = dmoc.discretize(dmoc.systems.free_rigid_body(RIGID_INERTIA), H), rk4_euler_step()
    in_space = dmoc.discretize(dmoc.systems.free_rigid_body(RIGID_INERTIA, mass=RIGID_MASS), H)
    funs = {"group": lambda steps: time_group(disc, steps),
            "group-vm": lambda steps: time_group(disc, steps, jit=False),
            "rk4-euler": lambda steps: time_rk4_euler(rk, steps),
            "se3": lambda steps: time_in_space(in_space, steps)}
    for fun in funs.values():
        fun(10)
    print("\nfree rigid body on SO(3); se3: the free body in space (m = 1.7, its momentum error"
          " that of x x p_x + R Pi, last column |p_x - p_x0|)")
    head = (f"{'steps':>7}  {'method':<10}{'eval us/step':>14}{'eval ratio':>12}"
            f"{'|E - E0|':>11}{'|R Pi - m0|':>13}{'|R^T R - I|':>13}")
    print(head + "\n" + "-" * len(head))
    for steps in horizons:
        runs = {method: [fun(steps) for _ in range(repeat)] for method, fun in funs.items()}
        rk_eval = min(r[0] for r in runs["rk4-euler"])
        for method, results in runs.items():
            ev, (dE, dm, dR, *dP) = min(r[0] for r in results), results[-1][2]
            print(f"{steps:>7}  {method:<10}{1e6 * ev / steps:>14.2f}{ev / rk_eval:>12.2f}"
                  f"{dE:>11.1e}{dm:>13.1e}{dR:>13.1e}" + "".join(f"{d:>13.1e}" for d in dP))


SPHERE = dict(inertia=np.array([1.0, 2.0, 2.5]), mass=1.3, radius=0.7)
SPHERE_OMEGA, E3 = np.array([1.0, -0.5, 2.0]), np.array([0.0, 0.0, 1.0])


def embedded_sphere(torques=False):
    """The Chaplygin sphere on R^11: q = (rows of R, x, y), R^T R = I as 6 holonomic rows;
    with `torques`, three body torques u (n_u = 3): the virtual work u . vee(skew(R^T dR))
    = 1/2 <R u^, dR>, so the generalized force on the entries of R is 1/2 R u^."""
    J, m, r = SPHERE["inertia"], SPHERE["mass"], SPHERE["radius"]
    J_d = ca.DM(np.diag(0.5 * J.sum() - J))
    v = ca.SX.sym("v", 11)

    def kinetic(q, v):
        Rdot = ca.reshape(v[:9], 3, 3).T
        return 0.5 * ca.trace(ca.mtimes([Rdot, J_d, Rdot.T])) + 0.5 * m * ca.sumsqr(v[9:])

    def rolling(q):
        R, Rdot = ca.reshape(q[:9], 3, 3).T, ca.reshape(v[:9], 3, 3).T
        omega = dmoc.mechanics.rotations.vee(ca.mtimes(Rdot, R.T))
        slip = v[9:] - r * ca.cross(omega, ca.DM(E3))[:2]
        return ca.jacobian(slip, v)

    def orthogonality(q):
        R = ca.reshape(q[:9], 3, 3).T
        gram = ca.mtimes(R.T, R) - ca.DM.eye(3)
        return ca.vertcat(*[gram[i, j] for i in range(3) for j in range(i, 3)])

    def torque(q, v, u):
        R = ca.reshape(q[:9], 3, 3).T
        return ca.vertcat(ca.reshape(0.5 * ca.mtimes(R, dmoc.mechanics.rotations.hat(u)).T, 9, 1),
                          ca.SX.zeros(2))

    return dmoc.MechanicalSystem(kinetic, 11, constraints=rolling, holonomic=orthogonality,
                                 **(dict(force=torque, n_u=3) if torques else {}))


def sphere_forms():
    """{form: (discretization, q0, v0)} of the two forms at the same start."""
    R0 = np.eye(3)
    rolling = SPHERE["radius"] * np.cross(R0 @ SPHERE_OMEGA, E3)[:2]
    group = dmoc.systems.chaplygin_sphere(SPHERE["inertia"], SPHERE["mass"], SPHERE["radius"])
    Rdot = R0 @ np.array(dmoc.mechanics.rotations.hat(SPHERE_OMEGA))
    return {"group": (dmoc.discretize(group, H), (R0, np.zeros(2)),
                      np.concatenate([SPHERE_OMEGA, rolling])),
            "embedded": (dmoc.discretize(embedded_sphere(), H), np.concatenate([R0.ravel(), [0, 0]]),
                         np.concatenate([Rdot.ravel(), rolling]))}


def sphere_errors(form, traj):
    """(|R^T R - I|, max |K_k - K_0|) of a run of `form`."""
    J, m, r = SPHERE["inertia"], SPHERE["mass"], SPHERE["radius"]
    if form == "group":
        R = traj.R
        K = np.einsum("kij,kj->ki", R, traj.Pi) + r * np.cross(E3, np.pad(traj.p_x, ((0, 0), (0, 1))))
    else:
        R = traj.q[:, :9].reshape(-1, 3, 3)
        Rdot = np.diff(traj.q[:, :9], axis=0).reshape(-1, 3, 3) / H   # chord velocities
        Rm = 0.5 * (R[1:] + R[:-1])
        W = np.einsum("kij,klj->kil", Rdot, Rm)
        omega = 0.5 * np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0],
                                W[:, 1, 0] - W[:, 0, 1]], axis=1)
        inertia = np.einsum("kij,j,klj->kil", Rm, J, Rm)
        K = np.einsum("kij,kj->ki", inertia, omega) + m * r ** 2 * (omega - omega[:, 2:] * E3)
    gram = np.einsum("kji,kjl->kil", R, R) - np.eye(3)
    return np.abs(gram).max(), np.abs(K - K[0]).max()


def one_sphere(form):
    """(this process) the first simulate(jit=True) of 10 steps of `form`: wall seconds."""
    disc, q0, v0 = sphere_forms()[form]
    tic = time.perf_counter()
    dmoc.simulate(disc, q0=q0, v0=v0, steps=10, jit=True)
    print(f"{time.perf_counter() - tic:.2f}")


def sphere_roll(form, steps=20, estimate=False):
    """The DMOC of tests/optimize/test_sphere_roll.py in `form` ("group", "embedded",
    "embedded-geo"), as a user builds and solves it: rest to rest from (I, 0) to a quarter
    turn about e3 at (1, 0.5) in 4 s, h = 4 / steps, cost sum h |u|^2 (u the body torques).
    Embedded: the goal's entries R_11, R_20, R_21 given and the other six free, those
    `OptimalControlProblem` names (with R^T R = I at q_N the nine would be imposed twice);
    "embedded" from its default guess, "embedded-geo" from the group form's default guess
    written entry by entry (R_k = exp(s_k pi/2 e3^), x_k = s_k x_goal, s_k the quintic shares of
    a rest-to-rest motion, `group_solving.timing`). After `dmoc.clear_caches`:
    (wall s, CPU s of this process and its children, both of build + solve; cost; IPOPT
    iterations; success; the verdict's status; max |R_N - R_goal|; with `estimate`, for the
    group form the result of ``optimize(problem, estimate=True)`` solved again, else None)."""
    goal, share = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), np.linspace(0, 1, steps + 1)
    dmoc.clear_caches()
    tic, cpu = time.perf_counter(), os.times()
    if form == "group":
        body = dmoc.systems.chaplygin_sphere(SPHERE["inertia"], SPHERE["mass"], SPHERE["radius"],
                                             torques=True)
        problem = dmoc.GroupOptimalControlProblem(
            dmoc.discretize(body, 4 / steps), steps, R_start=np.eye(3), R_goal=goal, x_start=[0.0, 0.0],
            x_goal=[1.0, 0.5])
        guess = None
    else:
        disc = dmoc.discretize(embedded_sphere(torques=True), 4 / steps)
        problem = dmoc.OptimalControlProblem(
            disc, steps, q_start=np.concatenate([np.eye(3).ravel(), [0.0, 0.0]]),
            q_goal=[None] * 4 + [goal[1, 1], None, goal[2, 0], goal[2, 1], None, 1.0, 0.5])
        way = share ** 3 * (10 - 15 * share + 6 * share ** 2)     # the group guess's `timing`
        c, s = np.cos(np.pi / 2 * way), np.sin(np.pi / 2 * way)
        zero, one = np.zeros_like(c), np.ones_like(c)
        q = np.stack([c, -s, zero, s, c, zero, zero, zero, one, way, 0.5 * way], axis=1)
        guess = (dmoc.Trajectory(4 * share, q, np.zeros_like(q), np.zeros((steps, disc.system.m)),
                                 np.zeros((steps, 3)), 4 / steps, "+") if form == "embedded-geo" else None)
    result = dmoc.optimize(problem, guess=guess, throw=False)
    wall, cpu_end = time.perf_counter() - tic, os.times()
    R_N = result.trajectory.R[-1] if form == "group" else result.trajectory.q[-1, :9].reshape(3, 3)
    verdict = str(getattr(result.verdict, "status", None))
    estimated = dmoc.optimize(problem, estimate=True, throw=False) if estimate and form == "group" else None
    return (wall, sum(cpu_end[:4]) - sum(cpu[:4]), result.cost, result.stats["iterations"],
            result.success, verdict, np.abs(R_N - goal).max(), estimated)


def sphere_table(repeat, steps, fresh, roll_steps=20):
    """The two forms of the Chaplygin sphere side by side, ratios group / embedded."""
    print("\nChaplygin sphere: group form (SO(3) x R^2) against the embedded R^11 form")
    head = (f"{'form':<10}{'first compile s':>16}{f'{steps:.0e} steps s':>16}{'ratio':>8}"
            f"{'|R^T R - I|':>13}{'|K - K0|':>11}")
    print(head + "\n" + "-" * len(head))
    rows = {}
    for form, (disc, q0, v0) in sphere_forms().items():
        with tempfile.TemporaryDirectory() as empty:
            first = (float(fresh_process("--one-sphere", form, env={"DMOC_CACHE_DIR": empty}))
                     if fresh else float("nan"))
        dmoc.simulate(disc, q0=q0, v0=v0, steps=10, jit=True)
        walls, traj = [], None
        for _ in range(repeat):
            res = dmoc.simulate(disc, q0=q0, v0=v0, steps=steps, jit=True)
            walls.append(res.stats["wall_time"])
            traj = res.trajectory
        rows[form] = (first, min(walls), *sphere_errors(form, traj))
    for form, (first, wall, dR, dK) in rows.items():
        ratio = wall / rows["embedded"][1]
        print(f"{form:<10}{first:>16.2f}{wall:>16.3f}{ratio:>8.2f}{dR:>13.1e}{dK:>11.1e}")
    print(f"first compile ratio group / embedded: {rows['group'][0] / rows['embedded'][0]:.2f}")
    print(f"\nDMOC, roll from rest to (1, 0.5) and a quarter turn in 4 s, N = {roll_steps} (build + "
          f"solve after clear_caches, best of {repeat}, the forms taking turns)")
    head = (f"{'form':<14}{'wall s':>8}{'CPU s':>8}{'ratio':>12}{'cost':>12}{'iter':>6}{'success':>9}"
            f"{'verdict':>16}{'|R_N - goal|':>14}")
    print(head + "\n" + "-" * len(head))
    forms, runs = ("embedded", "embedded-geo", "group"), []
    for _ in range(repeat):
        runs.append({form: sphere_roll(form, roll_steps) for form in forms})
    solves = {form: (min(r[form][0] for r in runs), min(r[form][1] for r in runs), *runs[-1][form][2:])
              for form in forms}
    for form, (wall, cpu, cost, iterations, success, verdict, dR, _) in solves.items():
        ratio = f"{wall / solves['embedded'][0]:.2f}/{cpu / solves['embedded'][1]:.2f}"
        print(f"{form:<14}{wall:>8.3f}{cpu:>8.3f}{ratio:>12}{cost:>12.6f}{iterations:>6}"
              f"{str(success):>9}{verdict:>16}{dR:>14.1e}")
    print(f"ratios wall/CPU against embedded; group against embedded-geo: "
          f"{solves['group'][0] / solves['embedded-geo'][0]:.2f}/"
          f"{solves['group'][1] / solves['embedded-geo'][1]:.2f}; cost group - embedded-geo: "
          f"{solves['group'][2] - solves['embedded-geo'][2]:.2e} (two discretizations, O(h^2))")
    if fresh:
        first = {"embedded-geo": [], "group": []}
        for _ in range(repeat):
            for form, walls in first.items():
                with tempfile.TemporaryDirectory() as empty:
                    walls.append(float(fresh_process("--one-roll", form, str(roll_steps),
                                                     env={"DMOC_CACHE_DIR": empty})))
        print(f"fresh processes, empty cache folder (the process's first build + solve, after "
              f"import), best of {repeat}: group {min(first['group']):.3f} s, embedded-geo "
              f"{min(first['embedded-geo']):.3f} s, ratio {min(first['group']) / min(first['embedded-geo']):.2f}")
    solves["group"] = sphere_roll("group", roll_steps, estimate=True)
    estimate = solves["group"][-1].stats.get("error_estimate")
    if estimate is None:                # the optimum failed its verdict: nothing estimated
        print(f"group, estimate=True: {solves['group'][-1].status}, no estimate")
        return
    print(f"group, estimate=True (a solve on N/2 steps and a replay on 2N): the estimate takes "
          f"{estimate['time']:.2f} s, {estimate['time'] / solves['group'][0]:.2f}x the group's first "
          f"solve; estimated cost error {estimate['cost_error']:.3e} ({estimate['cost']:.1e} "
          f"relative), end {estimate['final_state']:.1e}")


def table(repeat, name, horizons=(10**4, 10**5)):
    case = CASES[name]
    funs = methods(case)
    for fun in reversed(funs.values()):          # build, compile (jit=True before the default
        fun(10)                                  # path), load libraries, outside the timing
    print(f"\n{name}")
    head = (f"{'steps':>7}  {'method':<10}{'eval us/step':>14}{'total us/step':>15}"
            f"{'eval ratio':>12}{'total ratio':>13}{'max residual':>14}{'native':>8}{'|q(T)-q_exact|':>16}")
    print(head + "\n" + "-" * len(head))
    for steps in horizons:
        q_exact = case.exact(steps * H)
        runs = {method: best(repeat, fun, steps) for method, fun in funs.items()}
        rk = runs["rk4-ode"]
        for method, (ev, tot, q, rnorm, native) in runs.items():
            print(f"{steps:>7}  {method:<10}{1e6 * ev / steps:>14.2f}{1e6 * tot / steps:>15.2f}"
                  f"{ev / rk[0]:>12.2f}{tot / rk[1]:>13.2f}{rnorm:>14.1e}{str(native):>8}"
                  f"{np.linalg.norm(q - q_exact):>16.2e}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--one-run":
        one_run(argv[1], int(argv[2]))
        return
    if argv and argv[0] == "--one-sphere":
        one_sphere(argv[1])
        return
    if argv and argv[0] == "--one-roll":
        print(f"{sphere_roll(argv[1], int(argv[2]))[0]:.4f}")
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per case; best is kept (default 5)")
    parser.add_argument("--smallest", action="store_true",
                        help="10^3 steps once, no fresh processes (a smoke run, no figure)")
    args = parser.parse_args(argv)
    print(f"dmoc from {os.path.dirname(dmoc.__file__)}; python {platform.python_version()}, "
          f"casadi {ca.__version__}, load average {'%.2f %.2f %.2f' % os.getloadavg()}; "
          f"h = {H}, zero controls")
    for name in CASES:
        table(1 if args.smallest else args.repeat, name, (10**3,) if args.smallest else (10**4, 10**5))
    rigid_body_table(1 if args.smallest else args.repeat,
                     (10**3,) if args.smallest else (10**4, 10**5, 10**6))
    sphere_table(1 if args.smallest else args.repeat, 10**3 if args.smallest else 10**5,
                 fresh=not args.smallest, roll_steps=4 if args.smallest else 20)
    if args.smallest:
        print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")
        return
    print("ratios: against rk4-ode (RK4 on the hand-reduced ODE) at the same number of steps.")
    print("\nfresh processes (default path: wall s, peak RSS MB, native, max residual):")
    for name in CASES:
        print(f"  {name}, 10^6 steps, library cached: {fresh_process('--one-run', name, str(10**6))}")
        with tempfile.TemporaryDirectory() as empty:
            first = fresh_process("--one-run", name, str(10**6), env={"DMOC_CACHE_DIR": empty})
        print(f"  {name}, 10^6 steps, first run ever (empty cache): {first}")
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
