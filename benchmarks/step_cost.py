"""Benchmark: the cost of one implicit Dirac step against one explicit RK4 step, knife edge.

Dirac step: ``dmoc.simulate`` (midpoint rule, variant "+"): n + m = 4 equations of (37)
in the increment q1 - q0 and lam, three unrolled Newton iterations, evaluated over the
horizon in compiled ``mapaccum`` chunks; "dirac-jit" compiles the step to C (jit=True).
Baselines, each an SX step Function compiled with ``mapaccum``: "rk4-ode", classical RK4
on the hand-reduced ODE (x, y, theta, sigma, omega); "rk4-dae", RK4 on the index-1
Lagrange-d'Alembert DAE built from the same MechanicalSystem (a KKT solve per stage),
what a user with only L, A(q), f writes. All start from q0 = (0, 0, 0), v0 = (1, 0, 1)
(the unit circle), zero controls, h = 0.01, for 10^4 and 10^5 steps.

Reported per step: evaluation only (for dmoc ``stats["wall_time"]``, the step already
built by a warm-up call; for RK4 the mapaccum call) and total (the whole ``simulate``
call; for RK4 building the mapaccum plus the call). Best of `--repeat` runs. The
final-position error against the exact solution (dmoc.systems.knife_edge_solution) is
context: the Dirac step is second order and keeps omega_d = 0; RK4 is fourth order on the
ODE, and on the DAE it drifts off the constraint.

    python benchmarks/step_cost.py
"""

import argparse
import os
import platform
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.systems import knife_edge, knife_edge_solution  # noqa: E402

H = 0.01
Q0 = np.array([0.0, 0.0, 0.0])
V0 = np.array([1.0, 0.0, 1.0])


def rk4_step(mass=1.0, inertia=1.0):
    """(x, u, h) -> x_next: one classical RK4 step of the reduced knife-edge ODE."""
    x, u, h = ca.SX.sym("x", 5), ca.SX.sym("u", 2), ca.SX.sym("h")
    z = ca.SX.sym("z", 5)
    F = ca.Function("f", [z, u], [ca.vertcat(z[3] * ca.cos(z[2]), z[3] * ca.sin(z[2]), z[4],
                                             u[0] / mass, u[1] / inertia)])
    k1 = F(x, u)
    k2 = F(x + h / 2 * k1, u)
    k3 = F(x + h / 2 * k2, u)
    k4 = F(x + h * k3, u)
    return ca.Function("rk4_step", [x, u, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)],
                       ["x", "u", "h"], ["x_next"])


def dae_rk4_step(system):
    """(x, u, h) -> x_next: RK4 on the Lagrange-d'Alembert DAE of `system` in index-1 form.

    x = (q, v); the acceleration comes from the KKT system
    [M A^T; A 0] [a; -lam] = [f + dL/dq - (d/dq dL/dv) v; -(dA/dq v) v], M = d^2L/dv^2:
    what a user with only L, A(q), f(q, v, u) writes for an explicit integrator.
    """
    n, m = system.n, system.m
    q, v, u, h = ca.SX.sym("q", n), ca.SX.sym("v", n), ca.SX.sym("u", system.n_u), ca.SX.sym("h")
    L, A = system.lagrangian(q, v), system.constraint_matrix(q)
    p = ca.gradient(L, v)
    M, C = ca.jacobian(p, v), ca.jacobian(p, q)
    rhs = ca.vertcat(system.force(q, v, u) + ca.gradient(L, q) - ca.mtimes(C, v),
                     -ca.mtimes(ca.jacobian(ca.mtimes(A, v), q), v))
    kkt = ca.blockcat([[M, A.T], [A, ca.SX.zeros(m, m)]])
    acc = ca.solve(kkt, rhs)[:n]
    x = ca.vertcat(q, v)
    F = ca.Function("f", [x, u], [ca.vertcat(v, acc)])
    k1 = F(x, u)
    k2 = F(x + h / 2 * k1, u)
    k3 = F(x + h / 2 * k2, u)
    k4 = F(x + h * k3, u)
    return ca.Function("dae_rk4_step", [x, u, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])


DISC = dmoc.discretize(knife_edge(), H)


def time_dirac(steps, jit=False):
    """(evaluation seconds, total seconds, final q) of dmoc.simulate over `steps`.

    The discretization is built once (outside the timing, as a user re-running would);
    a first call compiles the step (and, with jit, the C code) before the timed runs.
    """
    tic = time.perf_counter()
    res = dmoc.simulate(DISC, q0=Q0, v0=V0, steps=steps, jit=jit)
    total = time.perf_counter() - tic
    if not res.success:
        raise RuntimeError(res.message)
    return res.stats["wall_time"], total, res.trajectory.q[-1]


def time_mapaccum(step, x0, steps):
    """(evaluation seconds, total seconds, final q) of a step Function over `steps`."""
    tic = time.perf_counter()
    horizon = step.mapaccum("horizon", steps)
    built = time.perf_counter()
    X = horizon(x0, np.zeros((2, steps)), H)
    done = time.perf_counter()
    return done - built, done - tic, np.array(X[:3, -1]).ravel()


METHODS = {
    "dirac": lambda steps: time_dirac(steps),
    "dirac-jit": lambda steps: time_dirac(steps, jit=True),
    "rk4-ode": lambda steps: time_mapaccum(rk4_step(), np.concatenate([Q0, [V0[0], V0[2]]]), steps),
    "rk4-dae": lambda steps: time_mapaccum(dae_rk4_step(knife_edge()), np.concatenate([Q0, V0]), steps),
}


def best(repeat, fun, steps):
    runs = [fun(steps) for _ in range(repeat)]
    return min(r[0] for r in runs), min(r[1] for r in runs), runs[-1][2]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per case; best is kept (default 5)")
    args = parser.parse_args(argv)
    print(f"python {platform.python_version()}, casadi {ca.__version__}, "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}; h = {H}, zero controls")
    for fun in METHODS.values():                    # load libraries, compile, outside the timing
        fun(10)
    head = (f"{'steps':>7}  {'method':<10}{'eval us/step':>14}{'total us/step':>15}"
            f"{'eval ratio':>12}{'total ratio':>13}{'|q(T)-q_exact|':>16}")
    print(head + "\n" + "-" * len(head))
    for steps in (10**4, 10**5):
        q_exact = knife_edge_solution(steps * H, Q0, V0)[0][0]
        runs = {name: best(args.repeat, fun, steps) for name, fun in METHODS.items()}
        rk4 = runs["rk4-ode"]
        for name, (ev, tot, q) in runs.items():
            print(f"{steps:>7}  {name:<10}{1e6 * ev / steps:>14.2f}{1e6 * tot / steps:>15.2f}"
                  f"{ev / rk4[0]:>12.1f}{tot / rk4[1]:>13.1f}"
                  f"{np.linalg.norm(q - q_exact):>16.2e}")
    print("ratios: against rk4-ode (RK4 on the hand-reduced ODE) at the same number of steps;")
    print("rk4-dae: RK4 on the index-1 Lagrange-d'Alembert DAE built from the same MechanicalSystem.")


if __name__ == "__main__":
    main()
