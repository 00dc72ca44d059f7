"""Baselines for the DMOC benchmark: the plain CasADi direct collocation a competent user
would write for the reduced nonholonomic ODE x' = F(x, u) (configuration and independent
velocities), trapezoidal and Hermite-Simpson, each built by mapping ONE per-interval
Function over the intervals (`Function.map`) and solved with IPOPT (exact Hessian).

Transcriptions (Betts 2010, Kelly 2017, "An introduction to trajectory optimization"):

trapezoid        x_{k+1} - x_k = h/2 (F_k + F_{k+1}),  cost h/2 (|u_k|^2 + |u_{k+1}|^2);
                 controls at the knots, piecewise LINEAR in time.
hermite_simpson  separated form: midpoint states x_{k+1/2} and midpoint controls u_{k+1/2}
                 are NLP variables, with
                 x_{k+1/2} = (x_k + x_{k+1})/2 + h/8 (F_k - F_{k+1}),
                 x_{k+1} - x_k = h/6 (F_k + 4 F_{k+1/2} + F_{k+1}),
                 cost h/6 (|u_k|^2 + 4 |u_{k+1/2}|^2 + |u_{k+1}|^2);
                 controls piecewise QUADRATIC through u_k, u_{k+1/2}, u_{k+1}.

The problems are written out from their equations of motion; the only thing taken from
dmoc is its default IPOPT options, so that every method is solved alike.
"""

import math
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from dmoc.optimal_control import DEFAULT_IPOPT_OPTIONS

IPOPT_OPTIONS = dict(DEFAULT_IPOPT_OPTIONS)
"""The IPOPT options every method of the benchmark gets (dmoc's DEFAULT_IPOPT_OPTIONS)."""

METHODS = ("trapezoid", "hermite_simpson")


@dataclass(frozen=True)
class ReducedProblem:
    """A rest-to-rest minimum-|u|^2 problem on the reduced ODE x' = F(x, u).

    Attributes
    ----------
    name : str
    ode : casadi.Function
        ``F(x, u) -> xdot``, x of shape (nx,), u of shape (nu,).
    rhs : callable
        ``rhs(x, u) -> xdot`` in plain Python floats, for scipy's integrators.
    duration : float
        The final time T.
    x_start, x_goal : ndarray, shape (nx,)
        Boundary states; NaN entries of `x_goal` are free.
    config, velocity : tuple of int
        Indices of the configuration and of the independent velocities in x.
    velocity_from_qdot : callable
        ``(q, qdot) -> w``, time-major (K, n_q) arrays to the independent velocities (K, n_w):
        used to build the initial guess from a configuration path.
    """

    name: str
    ode: ca.Function
    rhs: object
    duration: float
    x_start: np.ndarray
    x_goal: np.ndarray
    config: tuple
    velocity: tuple
    velocity_from_qdot: object

    @property
    def nx(self):
        return self.ode.size1_in(0)

    @property
    def nu(self):
        return self.ode.size1_in(1)


def knife_edge_problem(mass=1.0, inertia=1.0, duration=4.0, heading=0.0):
    """Problem A: knife-edge parallel parking (0, 0, heading) -> (0, 1, heading), at rest
    at both ends (heading 0 by default).

    x = (x, y, theta, sigma, omega): x' = sigma cos(theta), y' = sigma sin(theta),
    theta' = omega, m sigma' = u0 (force along the blade), J omega' = u1 (torque).
    """
    x, u = ca.SX.sym("x", 5), ca.SX.sym("u", 2)
    th, sigma, omega = x[2], x[3], x[4]
    xdot = ca.vertcat(sigma * ca.cos(th), sigma * ca.sin(th), omega, u[0] / mass, u[1] / inertia)
    ode = ca.Function("knife_edge_ode", [x, u], [xdot], ["x", "u"], ["xdot"])

    def rhs(z, w):
        return [z[3] * math.cos(z[2]), z[3] * math.sin(z[2]), z[4], w[0] / mass, w[1] / inertia]

    def velocity_from_qdot(q, qdot):
        sigma = np.cos(q[:, 2]) * qdot[:, 0] + np.sin(q[:, 2]) * qdot[:, 1]
        return np.column_stack([sigma, qdot[:, 2]])

    return ReducedProblem("knife_edge", ode, rhs, duration, np.array([0.0, 0.0, heading, 0.0, 0.0]),
                          np.array([0.0, 1.0, heading, 0.0, 0.0]), (0, 1, 2), (3, 4),
                          velocity_from_qdot)


def rolling_disk_problem(mass=1.0, radius=1.0, roll_inertia=0.5, steer_inertia=0.25,
                         duration=4.0):
    """Problem B: vertical rolling disk (0, 0, 0, 0) -> x = 1, y = 1, phi = pi/2, theta free.

    x = (x, y, theta, phi, Omega, w) with Omega = theta' (rolling rate), w = phi' (steering
    rate): x' = R cos(phi) Omega, y' = R sin(phi) Omega, (m R^2 + I) Omega' = u0,
    J w' = u1. Defaults are dmoc.systems.rolling_disk's (I = m R^2/2, J = m R^2/4).
    """
    x, u = ca.SX.sym("x", 6), ca.SX.sym("u", 2)
    phi, Omega, w = x[3], x[4], x[5]
    roll = mass * radius**2 + roll_inertia
    xdot = ca.vertcat(radius * ca.cos(phi) * Omega, radius * ca.sin(phi) * Omega, Omega, w,
                      u[0] / roll, u[1] / steer_inertia)
    ode = ca.Function("rolling_disk_ode", [x, u], [xdot], ["x", "u"], ["xdot"])

    def rhs(z, v):
        return [radius * math.cos(z[3]) * z[4], radius * math.sin(z[3]) * z[4], z[4], z[5],
                v[0] / roll, v[1] / steer_inertia]

    def velocity_from_qdot(q, qdot):
        return qdot[:, 2:4].copy()

    return ReducedProblem("rolling_disk", ode, rhs, duration, np.zeros(6),
                          np.array([1.0, 1.0, np.nan, np.pi / 2, 0.0, 0.0]), (0, 1, 2, 3),
                          (4, 5), velocity_from_qdot)


def guess_path(problem, tau):
    """The configuration guess dmoc.optimize uses by default, on normalized times `tau`.

    Straight line between the boundary configurations (a free goal component stays at its
    start value) plus the bump 0.1 max(1, max|goal - start|) sin(pi tau) on every component.

    Returns
    -------
    q, qdot : ndarray, shape (len(tau), n_q)
    """
    c = list(problem.config)
    start = problem.x_start[c]
    goal = np.where(np.isfinite(problem.x_goal[c]), problem.x_goal[c], start)
    bump = 0.1 * max(1.0, float(np.max(np.abs(goal - start))))
    tau = np.asarray(tau, dtype=float)[:, None]
    q = start + tau * (goal - start) + bump * np.sin(np.pi * tau)
    qdot = ((goal - start) + bump * np.pi * np.cos(np.pi * tau)) / problem.duration
    return q, qdot


def guess_states(problem, tau):
    """Initial-guess states (len(tau), nx): `guess_path` and its independent velocities."""
    q, qdot = guess_path(problem, tau)
    x = np.zeros((len(tau), problem.nx))
    x[:, list(problem.config)] = q
    x[:, list(problem.velocity)] = problem.velocity_from_qdot(q, qdot)
    return x


def trapezoid_interval(problem):
    """(x0, x1, u0, u1, h) -> (defect (nx,), cost): one trapezoidal interval."""
    nx, nu = problem.nx, problem.nu
    x0, x1, u0, u1 = (ca.SX.sym(s, k) for s, k in (("x0", nx), ("x1", nx), ("u0", nu), ("u1", nu)))
    h = ca.SX.sym("h")
    F = problem.ode
    defect = x1 - x0 - h / 2 * (F(x0, u0) + F(x1, u1))
    cost = h / 2 * (ca.sumsqr(u0) + ca.sumsqr(u1))
    return ca.Function("trapezoid_interval", [x0, x1, u0, u1, h], [defect, cost],
                       ["x0", "x1", "u0", "u1", "h"], ["defect", "cost"])


def hermite_simpson_interval(problem):
    """(x0, xm, x1, u0, um, u1, h) -> (midpoint defect, Simpson defect, cost): separated HS."""
    nx, nu = problem.nx, problem.nu
    x0, xm, x1 = (ca.SX.sym(s, nx) for s in ("x0", "xm", "x1"))
    u0, um, u1 = (ca.SX.sym(s, nu) for s in ("u0", "um", "u1"))
    h = ca.SX.sym("h")
    F = problem.ode
    f0, fm, f1 = F(x0, u0), F(xm, um), F(x1, u1)
    mid = xm - (x0 + x1) / 2 - h / 8 * (f0 - f1)
    simpson = x1 - x0 - h / 6 * (f0 + 4 * fm + f1)
    cost = h / 6 * (ca.sumsqr(u0) + 4 * ca.sumsqr(um) + ca.sumsqr(u1))
    return ca.Function("hermite_simpson_interval", [x0, xm, x1, u0, um, u1, h],
                       [mid, simpson, cost], ["x0", "xm", "x1", "u0", "um", "u1", "h"],
                       ["mid", "simpson", "cost"])


@dataclass
class CollocationResult:
    """Outcome of `solve`.

    Attributes
    ----------
    method : str
    steps : int
        Number of intervals N.
    t : ndarray, shape (N+1,)
    x : ndarray, shape (N+1, nx)
        Knot states.
    control_pieces : ndarray, shape (N, d+1, nu)
        Per interval, the control values at d+1 equally spaced local nodes (d = 1: linear
        through u_k, u_{k+1}; d = 2: quadratic through u_k, u_{k+1/2}, u_{k+1}).
    cost, success, status, iterations, n_variables, n_constraints
    construct_time, nlpsol_time, solve_time : float
        Seconds: NLP expression (per-interval Function, map), nlpsol creation, IPOPT call.
    """

    method: str
    steps: int
    t: np.ndarray
    x: np.ndarray
    control_pieces: np.ndarray
    cost: float
    success: bool
    status: str
    iterations: int
    construct_time: float
    nlpsol_time: float
    solve_time: float
    n_variables: int
    n_constraints: int

    @property
    def build_time(self):
        """construct_time + nlpsol_time."""
        return self.construct_time + self.nlpsol_time


def transcribe(problem, steps, method):
    """The NLP of `method` on `steps` intervals, built with one mapped per-interval Function.

    Returns
    -------
    nlp : dict
        ``{"x", "f", "g"}`` (MX); g = 0 are the collocation defects.
    blocks : dict
        name -> (offset, (rows, cols)) of the blocks of the NLP vector (column-major):
        ``x`` (nx, N+1), ``u`` (nu, N+1), and for Hermite-Simpson ``xm`` (nx, N), ``um`` (nu, N).
    """
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {METHODS}; got {method!r}.")
    nx, nu, N = problem.nx, problem.nu, steps
    h = problem.duration / N
    shapes = [("x", (nx, N + 1)), ("u", (nu, N + 1))]
    if method == "hermite_simpson":
        shapes += [("xm", (nx, N)), ("um", (nu, N))]
    blocks, offset = {}, 0
    for name, shape in shapes:
        blocks[name], offset = (offset, shape), offset + shape[0] * shape[1]
    w = ca.MX.sym("w", offset)
    V = {k: ca.reshape(w[o:o + s[0] * s[1]], *s) for k, (o, s) in blocks.items()}
    X, U = V["x"], V["u"]
    if method == "trapezoid":
        defect, cost = trapezoid_interval(problem).map(N)(X[:, :-1], X[:, 1:], U[:, :-1], U[:, 1:], h)
        g = ca.vec(defect)
    else:
        mid, simpson, cost = hermite_simpson_interval(problem).map(N)(
            X[:, :-1], V["xm"], X[:, 1:], U[:, :-1], V["um"], U[:, 1:], h)
        g = ca.vertcat(ca.vec(mid), ca.vec(simpson))
    return {"x": w, "f": ca.sum2(cost), "g": g}, blocks


def make_solver(nlp, name, *, expand=False, ipopt_options=None):
    """casadi.nlpsol with IPOPT, exact Hessian, `IPOPT_OPTIONS` updated by `ipopt_options`;
    `expand` turns the MX graph into SX."""
    merged = {**IPOPT_OPTIONS, **(ipopt_options or {})}
    opts = {"expand": expand, "print_time": False, "error_on_fail": False,
            **{"ipopt." + k: v for k, v in merged.items()}}
    return ca.nlpsol(name, "ipopt", nlp, opts)


def bounds(problem, blocks):
    """lbx, ubx: boundary states fixed at the first and last knot, NaN goal entries free."""
    size = sum(s[0] * s[1] for _, s in blocks.values())
    lbx, ubx = np.full(size, -np.inf), np.full(size, np.inf)
    o, (nx, cols) = blocks["x"]
    fixed = np.isfinite(problem.x_goal)
    for bound in (lbx, ubx):
        bound[o:o + nx] = problem.x_start
        last = o + nx * (cols - 1)
        bound[last:last + nx][fixed] = problem.x_goal[fixed]
    return lbx, ubx


def initial_guess(problem, blocks, steps):
    """NLP start vector: states from `guess_states`, controls zero."""
    size = sum(s[0] * s[1] for _, s in blocks.values())
    w0 = np.zeros(size)
    tau = np.linspace(0.0, 1.0, steps + 1)
    for name, times in (("x", tau), ("xm", (tau[:-1] + tau[1:]) / 2)):
        if name in blocks:
            o, (nx, cols) = blocks[name]
            w0[o:o + nx * cols] = guess_states(problem, times).ravel()
    return w0


def unpack(w, blocks, name):
    """Block `name` of the NLP vector as a time-major array (cols, rows)."""
    o, (rows, cols) = blocks[name]
    return np.asarray(w[o:o + rows * cols]).reshape(cols, rows)


def solve(problem, steps, method, *, expand=False, ipopt_options=None):
    """Transcribe and solve `method` on `steps` intervals, timing both (CollocationResult)."""
    tic = time.perf_counter()
    nlp, blocks = transcribe(problem, steps, method)
    construct_time = time.perf_counter() - tic
    solver = make_solver(nlp, method, expand=expand, ipopt_options=ipopt_options)
    nlpsol_time = time.perf_counter() - tic - construct_time
    lbx, ubx = bounds(problem, blocks)
    w0 = np.clip(initial_guess(problem, blocks, steps), lbx, ubx)
    n_g = solver.size1_out("g")
    tic = time.perf_counter()
    sol = solver(x0=w0, lbx=lbx, ubx=ubx, lbg=np.zeros(n_g), ubg=np.zeros(n_g))
    solve_time = time.perf_counter() - tic
    st = solver.stats()
    w = np.array(sol["x"]).ravel()
    u = unpack(w, blocks, "u")
    if method == "trapezoid":
        pieces = np.stack([u[:-1], u[1:]], axis=1)
    else:
        pieces = np.stack([u[:-1], unpack(w, blocks, "um"), u[1:]], axis=1)
    return CollocationResult(method, steps, np.linspace(0.0, problem.duration, steps + 1),
                             unpack(w, blocks, "x"), pieces, float(sol["f"]),
                             bool(st["success"]), st["return_status"], st.get("iter_count"),
                             construct_time, nlpsol_time, solve_time, w.size, n_g)
