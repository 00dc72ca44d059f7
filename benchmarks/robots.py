"""Benchmark: what a robot from its URDF costs as the number of joints grows (issue 44).

For serial chains of n revolute joints generated here as URDF text (n = 2, 4, 6, 8, 12:
links of 0.3 m hanging along -z, masses 3 kg x 0.85^i, axes cycling z, y, y, x, y, z) and for the shipped
models (`double_pendulum`, `arm6`, `arm7`): the build of `dmoc.RobotSystem` (adam's parse, the
links' recursion, the Lagrangian's Function; adam imported before), the SX size of L, the
first `simulate` in CasADi's virtual machine (`jit=False`: the step's Function built), the
virtual machine's step (a run of `--steps` steps), the first compiled run (`jit=True` with an
empty cache folder: the step's C compiled), the compiled step, and with `--dmoc` a
rest-to-rest DMOC end to end (problem built and `dmoc.optimize` judged, N = 20 over 1 s,
cost u^T u + 10 v^T v (0.1 v^T v on wheels, whose rates are many times the base's speed:
10 buys an impulsive start that 20 steps do not resolve), the file's limits, from q = 0.3
or the nearest point 0.6 inside the limits, each joint moving 0.5 to 0.2 in alternating
directions, a wheel's angle left free). Midpoint rule, h = 0.01, from q = 0.1 at rest
under zero torques (a small swing about the hanging rest, for any number of steps). Then
the log-log slope of each cost against n over the chains.

With `--breakdown`, where the step's cost goes: the instructions of the step's rows g(y)
(the residual the Newton iterations solve, y = (dq, nu, ds)), of their Jacobian dg/dy by
automatic differentiation and from the spatial second variation of L (the chord's, for a
fixed base under the midpoint rule: `dmoc.simulation.step_jacobian`), of one Newton update (g, dg/dy and J^{-1} g: QR for more than 4 unknowns) and of the fast
path's step (its unrolled updates and the step's end after common-subexpression
elimination: the compiled step; 8 chord updates with dg/dy factorized once for more than
4 unknowns, `dmoc.simulation.chord_update`), and of the fast step with Newton's 3 updates
instead (the fast path before the chord, the baseline: the same for 4 unknowns or fewer;
the fast step's instructions over it in brackets); with `--dmoc`, the DMOC's IPOPT iterations and the
seconds of one (IPOPT's time over its iterations). `--hessian limited-memory` solves the
DMOC with IPOPT's quasi-Newton Hessian instead of the exact one.

With `--versus-newton`, the compiled fast step's CPU time with the chord, with the chord
stopping at the tail alone (`tail_stop`: a step whose updates reach their round-off floor
above CHORD_STOP_TOL takes all 8), with the chord before its updates stopped once converged
(all 8, J factorized by CasADi's QR: the baseline, `chord_before`), with the chord whose
Jacobian is CasADi's automatic one (the chord before the spatial Jacobian) and with
Newton's 3 updates (the fast path before the chord, its stepper built with the chord
switched off), interleaved, the best of `--repeat` runs of `--steps` steps each from the
same state as the timed runs, as ratios, with the largest difference of the runs' final
states from the chord's and the log-log slope of each over the chains (and over 6+ joints)
(`--no-compile`: in the virtual machine; `--smallest` also runs it so, at --repeat 1).

With `--kept-jacobian` (in `--smallest` for 6 joints), how many chord updates a step takes
(until the error they leave is at most CHORD_UPDATE_TOL) with J fresh at the warm start
(the baseline, as the fast path has it), with J kept across steps and refactorized after
a step of more than 6 updates or a rate above 0.01 (as stiff ODE codes keep it), and fresh
at the warm start extrapolated from the two previous steps, 2 dq_{k-1} - dq_{k-2}; and how
many the fast path takes (J fresh, at most 8: `chord_update.more_updates`), and took
stopping at the tail alone (`tail_stopped`).

With `--mobile` (and in `--smallest`), the shipped mobile manipulator `mobile_arm` twice: its
file as a fixed-base robot (the baseline: the wheels spin in the air) and on its wheels
(`wheels=`: the base's pose x, y, theta added, three rolling rows), each cost of the wheeled
one also as a ratio over the fixed one's.

With `--floating` (and in `--smallest`), the shipped satellite `space_arm` twice: its file as
a fixed-base robot (the baseline: the satellite bolted down) and on its floating base
(`dmoc.FloatingBaseRobot`: the base's rotation R on SO(3) and position p added, stepped on
the group, from R = I, x = 0.1), each cost also as a ratio over the fixed one's; its DMOC
is the zero-momentum turn of the satellite by 0.15 rad (the falling cat of docs/robots.md,
N = 20 over 6 s, no gravity), not comparable with the fixed base's rest-to-rest one.

With `--alternatives`, the Hessian of L in (q, v) (what the step's Newton Jacobian is made
of) three ways for each model: dmoc's L from the links' recursion (the baseline), and
L = 1/2 v^T M(q) v - V(q) with adam's composite rigid body algorithm M(q) and centre of
mass V(q), either expanded in one SX graph (dmoc's L before the recursion) or called as
Functions in an MX graph; each one's size in instructions, its build and its evaluation in
CasADi's virtual machine (best of 3 x 200 calls at a random state), as ratios over the
baseline's, and the largest difference from it.

    python benchmarks/robots.py                         # chains of 2-12 joints, compiled
    python benchmarks/robots.py --alternatives --no-compile --joints 2 4 6 8 12 --shipped
    python benchmarks/robots.py --mobile --dmoc --joints 2 4 6   # the mobile manipulator
    python benchmarks/robots.py --floating --dmoc --joints 2     # the floating satellite
    python benchmarks/robots.py --breakdown --dmoc --no-compile --steps 2000   # where the cost goes
    python benchmarks/robots.py --versus-newton --steps 20000   # the chord against Newton, CPU
    python benchmarks/robots.py --kept-jacobian --joints 6 8 12 --steps 2000   # J across steps
    python benchmarks/robots.py --smallest      # = --joints 2 --steps 20 --no-compile
                                                #   --alternatives --mobile --floating
                                                #   --breakdown, then --versus-newton
                                                #   --no-compile --joints 2 6 --steps 20,
                                                #   --kept-jacobian --joints 6 --steps 20
"""

import argparse
import os
import pathlib
import tempfile
import time
import timeit
from unittest import mock

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.mechanics.robots import example_urdf  # noqa: E402
from dmoc.principle.residual import step_residual  # noqa: E402
from dmoc.simulation import chord_update, fast_path  # noqa: E402
from dmoc.simulation.fast_path import fast_step  # noqa: E402
from dmoc.simulation.step_jacobian import step_jacobian  # noqa: E402
from dmoc.simulation.schur_complement import newton_update  # noqa: E402
from dmoc.simulation import stepper as stepper_module  # noqa: E402
from dmoc.simulation.stepper import DiracStepper  # noqa: E402

AXES = ("0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "0 0 1")
LINK, RADIUS = 0.3, 0.04
H = 0.01


def chain_urdf(n):
    """URDF text of a serial chain of n revolute joints (solid cylinders along z)."""
    parts = ['<?xml version="1.0"?>', f'<robot name="chain{n}">', '<link name="link0"/>']
    for i in range(n):
        m = 3.0 * 0.85 ** i
        axial, across = m * RADIUS ** 2 / 2, m * (3 * RADIUS ** 2 + LINK ** 2) / 12
        parts += [
            f'<joint name="j{i + 1}" type="revolute"><parent link="link{i}"/>'
            f'<child link="link{i + 1}"/><origin xyz="0 0 {-LINK if i else 0.0}" rpy="0 0 0"/>'
            f'<axis xyz="{AXES[i % len(AXES)]}"/>'
            f'<limit lower="-3.1416" upper="3.1416" velocity="3" effort="100"/>'
            f'<dynamics damping="0.1"/></joint>',
            f'<link name="link{i + 1}"><inertial><origin xyz="0 0 {-LINK / 2}" rpy="0 0 0"/>'
            f'<mass value="{m}"/><inertia ixx="{across}" ixy="0" ixz="0" iyy="{across}" '
            f'iyz="0" izz="{axial}"/></inertial></link>']
    return "\n".join(parts + ["</robot>"])


def seconds(call):
    tic = time.perf_counter()
    value = call()
    return time.perf_counter() - tic, value


def simulated(system, steps, jit):
    """(wall seconds of the call, its result) of `steps` midpoint steps from q = 0.1."""
    disc = dmoc.discretize(system, H)
    return seconds(lambda: dmoc.simulate(disc, q0=np.full(system.n, 0.1), v0=np.zeros(system.n),
                                         steps=steps, jit=jit))


def rest_to_rest(system, steps=20, hessian="exact"):
    """Seconds of a judged rest-to-rest DMOC over 1 s (problem built and solved), its
    verdict and its stats; IPOPT's Hessian `hessian` ("exact" or "limited-memory")."""
    lower, upper = system.position_limits
    q_start = np.clip(0.3, lower + 0.6, upper - 0.6)       # 0.3 where the limits allow it
    q_goal = q_start + np.linspace(0.5, 0.2, system.n) * np.where(np.arange(system.n) % 2, -1, 1)
    wheels = {3 + w.index for w in system.wheels}
    q_goal = [None if i in wheels else x for i, x in enumerate(q_goal)]
    weight = 0.1 if system.wheels else 10

    def solve():
        problem = dmoc.OptimalControlProblem(
            dmoc.discretize(system, 1.0 / steps), steps, q_start=q_start, q_goal=q_goal,
            v_start=np.zeros(system.n), control_bounds=system.effort_limits,
            state_bounds=system.position_limits,
            running_cost=lambda q, v, u: ca.sumsqr(u) + weight * ca.sumsqr(v))
        return dmoc.optimize(problem, throw=False, options={"hessian_approximation": hessian})

    wall, result = seconds(solve)
    return wall, result.verdict.status if result.verdict else result.status, result.stats


def newton_parts(system):
    """Instructions of the parts of one simulation step (see `--breakdown`)."""
    stepper = DiracStepper(step_residual(dmoc.discretize(system, H)), 1e-12, 50)
    _, _, _, params, guess = stepper.symbols(ca.SX)
    y = ca.SX.sym("y", guess.numel())
    g = stepper.equations(y, params)[0]

    def count(expression):
        return ca.Function("part", [y, params], [expression]).n_instructions()

    parts = {"g": count(g), "dg/dy": count(ca.jacobian(g, y)),
             "dg/dy spatial": count(ca.cse(ca.densify(step_jacobian(stepper, g, y, params)))),
             "update": count(newton_update(g, y, stepper.unknowns)),
             "fast step": fast_instructions(stepper)}
    with chord_before():           # the same as "fast step" for Newton's updates
        parts["chord before"] = fast_instructions(stepper)
    if stepper.chord:
        parts["further update"] = fast_instructions(stepper, "chord_further")
    stepper.chord = False          # the fast path's updates are read from the stepper
    return {**parts, "Newton fast step": fast_instructions(stepper)}


def fast_instructions(stepper, part=None):
    """Instructions of the compiled fast step of `stepper`: of the SX Function itself
    (Newton's updates, the chord before), or for the chord the sum of its step's start
    (factorization and an update), one further update and its end, i.e. a step whose
    updates converge in FIRST_CHORD_UPDATES = 2; of its SX Function `part` alone when given
    ("chord_further": one more update)."""
    fast = fast_step(stepper, eliminate=True)
    if not stepper.chord:
        return fast.n_instructions()
    if fast.is_a("SXFunction"):                 # `chord_before_step`
        return fast.n_instructions()
    names = [part] if part else ["chord_start", "chord_further", "step_ends"]
    return sum(fast.find_function(name).n_instructions() for name in names)


def tail_stop():
    """The chord's stop before updates at the round-off floor counted (the baseline of
    `--versus-newton` and `--kept-jacobian`): a further update while the geometric tail at
    the last rate (`remaining_error`) exceeds CHORD_STOP_TOL, `tail_stopped` in place of
    `chord_update.more_updates` while the block runs."""
    return mock.patch.object(fast_path, "more_updates", tail_stopped)


def tail_stopped(last, before, rate_before):
    """`chord_update.more_updates` before the round-off floor: the tail at the last rate."""
    return chord_update.remaining_error(last, before) > chord_update.CHORD_STOP_TOL


def chord_before():
    """The chord's fast step before its updates stopped once converged (the baseline of
    `--versus-newton` and `--breakdown`): `chord_before_step` in place of the fast path's
    while the block runs."""
    return mock.patch.object(fast_path, "_chord_step", chord_before_step)


def chord_before_step(stepper, rows, eliminate):
    """The chord's fast step as it was: one SX Function after ``ca.cse`` (also without
    `eliminate`) of J = Q R by CasADi's QR at the warm start, all CHORD_ITERATIONS updates
    R^{-1} Q^T g by back substitution, and the step's end."""
    state, u, h, params, guess = stepper.symbols(ca.SX)
    ys, ps, g, J = rows
    n = ys.numel()
    factors = ca.Function("QR", [ys, ps], [ca.densify(F) for F in ca.qr(step_jacobian(stepper, g, ys, ps, J))])
    Q, R = ca.SX.sym("Q", n, n), ca.SX.sym("R", n, n)
    b, x = ca.mtimes(Q.T, g), [None] * n
    for i in reversed(range(n)):
        x[i] = (b[i] - sum((R[i, j] * x[j] for j in range(i + 1, n)), ca.SX(0))) / R[i, i]
    chord = ca.Function("chord_update", [ys, ps, Q, R], [ca.vertcat(*x)])
    QR = factors(guess, params)
    y, sizes = guess, []
    for _ in range(fast_path.CHORD_ITERATIONS):
        delta = chord(y, params, *QR)
        y = y - delta
        sizes.append(ca.norm_inf(delta) / (1 + ca.norm_inf(y)))
    solved = stepper.wrap(state, params, y, chord_update.remaining_error(sizes[-1], sizes[-2]))
    return ca.Function("dirac_step_fast", [state, u, h], [ca.densify(o) for o in ca.cse(list(solved))],
                       ["state", "u", "h"], ["next", "out"])


def versus_newton(system, steps, repeat, compile_):
    """{"chord", "chord, AD", "Newton": the best CPU seconds of one fast step (compiled with
    `compile_`, else in the virtual machine) over `repeat` interleaved runs of `steps` steps
    from q = 0.1 at rest, "differences": {each other one: its final state's largest
    difference from the chord's}}, "chord, tail stop" the chord stopped at the tail alone
    (`tail_stop`),
    the "chord, AD" stepper's Jacobian by ``ca.jacobian`` instead of the spatial second
    variation (`step_jacobian`), the Newton stepper built with `uses_chord` switched off."""
    disc = dmoc.discretize(system, H)
    residual, chord, jacobian = step_residual(disc), stepper_module.uses_chord, fast_path.step_jacobian
    steppers = {"chord": DiracStepper(residual, 1e-12, 50, native=compile_)}
    with tail_stop():
        steppers["chord, tail stop"] = DiracStepper(residual, 1e-12, 50, native=compile_)
    with chord_before():
        steppers["chord before"] = DiracStepper(residual, 1e-12, 50, native=compile_)
    try:
        fast_path.step_jacobian = lambda stepper, g, y, params, automatic: automatic
        steppers["chord, AD"] = DiracStepper(residual, 1e-12, 50, native=compile_)
        fast_path.step_jacobian = jacobian
        stepper_module.uses_chord = lambda stepper, rows: False
        steppers["Newton"] = DiracStepper(residual, 1e-12, 50, native=compile_)
    finally:
        stepper_module.uses_chord, fast_path.step_jacobian = chord, jacobian
    n = system.n
    p0 = dmoc.simulate(disc, q0=np.full(n, 0.1), v0=np.zeros(n), steps=1, jit=False).trajectory.p[0]
    start = np.concatenate([np.full(n, 0.1), p0, np.zeros(steppers["chord"].state.size - 2 * n)])
    best, final = {k: np.inf for k in steppers}, {}
    for _ in range(repeat):
        for k, stepper in steppers.items():
            tic = time.process_time()
            acc, _, failed, *_ = stepper.run(start, np.zeros((steps, system.n_u)), H)
            best[k] = min(best[k], (time.process_time() - tic) / steps)
            assert failed is None and len(acc) == steps + 1
            final[k] = acc[-1, :2 * n]
    others = [k for k in final if k != "chord"]
    return {**best, "differences": {k: np.abs(final["chord"] - final[k]).max() for k in others}}


def kept_jacobian(system, steps):
    """{way: (mean, largest) chord updates a step, "refreshed": the fraction of steps that
    refactorized} of the chord (`--kept-jacobian`) along `steps` midpoint steps from q = 0.1
    at rest, in numpy with the step's rows g and Jacobian (`step_jacobian`) as Functions:
    until the error the updates leave (`remaining_error`) is at most CHORD_UPDATE_TOL, or
    40 updates; J^{-1} by numpy."""
    disc = dmoc.discretize(system, H)
    stepper = DiracStepper(step_residual(disc), 1e-12, 50)
    ys, params, g, J = fast_path.step_rows(stepper)
    rows = ca.Function("g", [ys, params], [g])
    jacobian = ca.Function("J", [ys, params], [step_jacobian(stepper, g, ys, params, J)])
    n = system.n
    traj = dmoc.simulate(disc, q0=np.full(n, 0.1), v0=np.zeros(n), steps=steps, jit=False).trajectory

    def updates(y, p, inverse):
        """(updates until the error they leave is at most CHORD_UPDATE_TOL, the rate then,
        the updates the fast path takes, `chord_update.more_updates`, and those it took
        stopping at the tail alone, `tail_stopped`: at most CHORD_ITERATIONS)."""
        before, rate_before, found = None, np.inf, {}
        for k in range(1, 41):
            delta = inverse @ np.array(rows(y, p)).ravel()
            y = y - delta
            last = np.abs(delta).max() / (1 + np.abs(y).max())
            if before is not None:
                rate, error = last / before, float(chord_update.remaining_error(last, before))
                if error <= chord_update.CHORD_UPDATE_TOL:
                    found.setdefault("tol", (k, rate))
                for way, more in (("stop", chord_update.more_updates), ("tail stop", tail_stopped)):
                    stopped = not float(more(*map(ca.DM, (last, before, rate_before))))
                    if stopped or k == chord_update.CHORD_ITERATIONS:
                        found.setdefault(way, k)
                if len(found) == 3:
                    break
                rate_before = rate
            before = last
        return (*found.get("tol", (k, rate)), found["stop"], found["tail stop"])

    ways = ("fresh", "kept", "extrapolated", "stop", "tail stop")
    counts, kept, refreshed = {way: [] for way in ways}, None, 0
    for k in range(2, steps):
        p = np.concatenate([traj.q[k], traj.p[k], np.zeros(system.n_u), [H]])
        last, earlier = traj.q[k] - traj.q[k - 1], traj.q[k - 1] - traj.q[k - 2]
        for way, y in (("fresh", last), ("extrapolated", 2 * last - earlier)):
            counted, _, taken, tail_taken = updates(y, p, np.linalg.inv(np.array(jacobian(y, p))))
            counts[way].append(counted)
            if way == "fresh":
                counts["stop"].append(taken)
                counts["tail stop"].append(tail_taken)
        if kept is None:
            kept = np.linalg.inv(np.array(jacobian(last, p)))
        taken, rate, *_ = updates(last, p, kept)
        counts["kept"].append(taken)
        if taken > 6 or rate > 0.01:            # refactorize for the next step
            kept, refreshed = np.linalg.inv(np.array(jacobian(last, p))), refreshed + 1
    return {**{way: (np.mean(c), max(c)) for way, c in counts.items()}, "refreshed": refreshed / (steps - 2)}


def report_kept_jacobian(rows):
    print("Chord updates a step to leave CHORD_UPDATE_TOL (mean, largest):")
    print("| model | n | J fresh at the warm start | J kept across steps | refactorized | "
          "fresh at the extrapolated warm start | the fast path's (fresh, `more_updates`) | "
          "stopped at the tail alone |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        v = r["kept"]
        print(f"| {r['model']} | {r['n']} | " + " | ".join(
            f"{v[way][0]:.2f}, {v[way][1]}" for way in ("fresh", "kept")) + f" | {v['refreshed']:.0%} | "
            f"{v['extrapolated'][0]:.2f}, {v['extrapolated'][1]} | {v['stop'][0]:.2f}, {v['stop'][1]} | "
            f"{v['tail stop'][0]:.2f}, {v['tail stop'][1]} |")


def report_versus_newton(rows, compiled):
    others = ("chord, tail stop", "chord before", "chord, AD", "Newton")
    print(f"Fast step, {'compiled' if compiled else 'virtual machine'}, CPU (best of interleaved runs):")
    print("| model | n | chord | chord, tail stop | chord before | chord, AD Jacobian | Newton (3 updates) "
          "| ratios | final states differ by |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        v = r["versus"]
        ratios = ", ".join(f"{v['chord'] / v[k]:.2f}" for k in others)
        differences = ", ".join(f"{v['differences'][k]:.1e}" for k in others)
        print(f"| {r['model']} | {r['n']} | " + " | ".join(f"{v[k] * 1e6:.3f} us" for k in ("chord", *others))
              + f" | {ratios} | {differences} |")
    for label, chosen in (("", rows), (" over 6+ joints", [r for r in rows if r["n"] >= 6])):
        if len(chosen) >= 2:
            print(f"log-log slopes{label}: " + ", ".join(
                f"{k} {slope([{'n': r['n'], k: r['versus'][k]} for r in chosen], k):.2f}"
                for k in ("chord", *others)))


def measure(name, path, args, wheels=None):
    """One row: the costs of the model at `path` (on its `wheels` when given)."""
    steps, compile_, dmoc_ = args.steps, args.compile, args.dmoc
    build, system = seconds(lambda: dmoc.RobotSystem(path, wheels=wheels))
    row = {"model": name, "n": system.n, "build": build,
           "L nodes": system.lagrangian.n_instructions()}
    if args.versus_newton:
        return {**row, "versus": versus_newton(system, steps, args.repeat, compile_)}
    if args.kept_jacobian:
        return {**row, "kept": kept_jacobian(system, steps)}
    row["first vm"], _ = simulated(system, 10, False)
    wall, result = simulated(system, steps, False)
    row["vm step"] = wall / steps
    assert result.success, result.message
    if compile_:
        row["first compiled"], _ = simulated(system, 10, True)
        wall, result = simulated(system, steps, True)
        row["compiled step"] = wall / steps
        assert result.success and result.stats["native"], result.message
    if dmoc_:
        row["dmoc"], row["verdict"], stats = rest_to_rest(system, hessian=args.hessian)
        row["iterations"] = stats["iterations"]
        row["per iteration"] = stats["ipopt_time"] / max(stats["iterations"], 1)
    if args.breakdown:
        row.update(newton_parts(system))
    return row


def measure_floating(args):
    """One row: the costs of `space_arm` on its floating base (see `--floating`)."""
    path = example_urdf("space_arm")
    build, robot = seconds(lambda: dmoc.FloatingBaseRobot(path))
    row = {"model": "space_arm (floating)", "n": robot.n, "build": build,
           "L nodes": robot.kinetic_energy.n_instructions() + robot.potential.n_instructions()}

    def run(steps, jit):
        disc = dmoc.discretize(robot, H)
        return seconds(lambda: dmoc.simulate(disc, q0=(np.eye(3), np.full(robot.n_x, 0.1)),
                                             v0=np.zeros(robot.n), steps=steps, jit=jit))

    for first, step, jit in (("first vm", "vm step", False), ("first compiled", "compiled step", True)):
        if jit and not args.compile:
            break
        row[first], _ = run(10, jit)
        wall, result = run(args.steps, jit)
        row[step] = wall / args.steps
        assert result.success, result.message
    if args.dmoc:
        row["dmoc"], row["verdict"], stats = falling_cat()
        row["iterations"] = stats["iterations"]      # the group's solve: solve_time is IPOPT's
        row["per iteration"] = stats["solve_time"] / max(stats["iterations"], 1)
    return row


def falling_cat(steps=20, duration=6.0, angle=0.15):
    """Seconds, verdict and stats of the judged zero-momentum turn of `space_arm`'s
    satellite by `angle` about its z axis (docs/robots.md, "A floating base")."""
    robot = dmoc.FloatingBaseRobot(example_urdf("space_arm"), gravity=0.0)
    c, s = np.cos(angle), np.sin(angle)
    R_goal = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    c0 = np.array(robot.center_of_mass(np.concatenate([np.eye(3).ravel(), np.zeros(robot.n_x)]))).ravel()
    lower, upper = robot.position_limits

    def solve():
        problem = dmoc.GroupOptimalControlProblem(
            dmoc.discretize(robot, duration / steps), steps, R_start=np.eye(3), R_goal=R_goal,
            x_start=np.zeros(robot.n_x), x_goal=np.concatenate([c0 - R_goal @ c0, np.zeros(robot.n_u)]),
            path_constraints=lambda R, x, u: ca.vertcat(x[3:] - upper, lower - x[3:]))
        return dmoc.optimize(problem, throw=False)

    wall, result = seconds(solve)
    return wall, result.verdict.status if result.verdict else result.status, result.stats


def crba_lagrangian(path, gravity=9.81):
    """L(q, v) = 1/2 v^T M(q) v - V(q) with M(q) of adam's composite rigid body algorithm
    and V(q) = g m z_com(q) of its centre of mass, both as SX Functions of q: what
    dmoc.RobotSystem built before the links' recursion."""
    from adam.casadi import KinDynComputations
    from dmoc.mechanics.robots.urdf_file import read_urdf
    joints, text = read_urdf(pathlib.Path(path))
    model = KinDynComputations(text, [j.name for j in joints])
    q, base = ca.SX.sym("q", len(joints)), ca.SX.eye(4)
    M = ca.Function("M", [q], [ca.SX(model.mass_matrix(base, q)[6:, 6:])])
    V = ca.Function("V", [q], [ca.SX(gravity * model.get_total_mass()
                                     * model.CoM_position(base, q)[2])])
    return lambda q, v: 0.5 * ca.bilin(M(q), v, v) - V(q)


def alternatives(name, path):
    """Rows of the Hessian of L in (q, v) built three ways (see the module's notes)."""
    system = dmoc.RobotSystem(path)
    crba = crba_lagrangian(path)
    rng = np.random.default_rng(0)
    q0, v0 = rng.uniform(-1, 1, system.n), rng.uniform(-1, 1, system.n)
    rows = []
    for way, kind, lagrangian in (("recursion (dmoc)", ca.SX, system.lagrangian),
                                  ("CRBA, expanded SX", ca.SX, crba),
                                  ("CRBA, called in MX", ca.MX, crba)):
        q, v = kind.sym("q", system.n), kind.sym("v", system.n)
        build, H = seconds(lambda: ca.Function(
            "H", [q, v], [ca.hessian(lagrangian(q, v), ca.vertcat(q, v))[0]]))
        value = np.array(H(q0, v0))
        evaluation = min(timeit.repeat(lambda: H(q0, v0), number=200, repeat=3)) / 200
        rows.append({"model": name, "way": way, "instructions": H.n_instructions(),
                     "build": build, "evaluation": evaluation, "value": value})
    return rows


def report_alternatives(rows):
    print("Hessian of L in (q, v), ratios over the recursion's:")
    print("| model | way | instructions | build | evaluation (VM) | max difference |")
    print("|---|---|---:|---:|---:|---:|")
    for r in rows:
        base = next(b for b in rows if b["model"] == r["model"])
        print(f"| {r['model']} | {r['way']} | {r['instructions']} "
              f"({r['instructions'] / base['instructions']:.2f}x) | {r['build'] * 1e3:.1f} ms "
              f"({r['build'] / base['build']:.2f}x) | {r['evaluation'] * 1e3:.4f} ms "
              f"({r['evaluation'] / base['evaluation']:.2f}x) | "
              f"{np.abs(r['value'] - base['value']).max():.1e} |")


def slope(rows, key):
    n = np.array([r["n"] for r in rows], float)
    y = np.array([r[key] for r in rows], float)
    return np.polyfit(np.log(n), np.log(y), 1)[0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--joints", type=int, nargs="+", default=[2, 4, 6, 8, 12],
                        help="chain sizes (default 2 4 6 8 12)")
    parser.add_argument("--steps", type=int, default=2000, help="steps of a timed run")
    parser.add_argument("--compile", action=argparse.BooleanOptionalAction, default=True,
                        help="also the first compile and the compiled step (default on)")
    parser.add_argument("--dmoc", action="store_true", help="also a rest-to-rest DMOC")
    parser.add_argument("--shipped", action="store_true",
                        help="also the shipped double_pendulum, arm6 and arm7")
    parser.add_argument("--mobile", action="store_true",
                        help="also mobile_arm with its base fixed and on its wheels")
    parser.add_argument("--floating", action="store_true",
                        help="also space_arm with its base fixed and floating")
    parser.add_argument("--alternatives", action="store_true",
                        help="also the Hessian of L built from adam's CRBA, expanded or called")
    parser.add_argument("--breakdown", action="store_true",
                        help="also the instructions of the step's rows, Jacobian, update and "
                             "fast step")
    parser.add_argument("--versus-newton", action="store_true",
                        help="only the fast step's CPU time with the chord and with Newton's 3 "
                             "updates, over the chains (compiled unless --no-compile)")
    parser.add_argument("--kept-jacobian", action="store_true",
                        help="only the chord's updates a step with J fresh, kept across steps "
                             "and at an extrapolated warm start, over the chains")
    parser.add_argument("--repeat", type=int, default=7,
                        help="interleaved runs of --versus-newton (default 7; the best counts)")
    parser.add_argument("--hessian", choices=("exact", "limited-memory"), default="exact",
                        help="IPOPT's Hessian in the DMOC (default exact)")
    parser.add_argument("--smallest", action="store_true",
                        help="the smallest run: --joints 2 --steps 20 --no-compile "
                             "--alternatives --mobile --floating --breakdown, then --versus-newton "
                             "and --kept-jacobian at their smallest")
    args = parser.parse_args(argv)
    if args.smallest:
        args.joints, args.steps, args.compile = [2], 20, False
        args.alternatives = args.mobile = args.floating = args.breakdown = True
        main(["--versus-newton", "--no-compile", "--joints", "2", "6", "--steps", "20", "--repeat", "1"])
        main(["--kept-jacobian", "--joints", "6", "--steps", "20"])
    import adam.casadi  # noqa: F401  (its import, ~1 s, is not the build's)
    if args.versus_newton or args.kept_jacobian:
        args.shipped = args.mobile = args.floating = args.alternatives = False

    with tempfile.TemporaryDirectory(prefix="dmoc-robots-") as folder:
        os.environ["DMOC_CACHE_DIR"] = os.path.join(folder, "cache")   # an empty cache
        models = []
        for n in args.joints:
            path = os.path.join(folder, f"chain{n}.urdf")
            with open(path, "w") as file:
                file.write(chain_urdf(n))
            models.append((f"chain-{n}", path))
        models += [(name, example_urdf(name))
                   for name in (("double_pendulum", "arm6", "arm7") if args.shipped else ())]
        rows = [measure(name, path, args) for name, path in models]
        if args.mobile:
            rows += [measure(f"mobile_arm{label}", example_urdf("mobile_arm"), args, wheels)
                     for label, wheels in ((" (fixed base)", None),
                                           (" (wheeled)", ("left_wheel", "right_wheel")))]
        if args.floating:
            rows.append(measure("space_arm (fixed base)", example_urdf("space_arm"), args))
            rows.append({**measure_floating(args), "over": rows[-1]})
        ways = [row for name, path in models for row in alternatives(name, path)] \
            if args.alternatives else []
    if args.versus_newton:
        return report_versus_newton(rows, args.compile)
    if args.kept_jacobian:
        return report_kept_jacobian(rows)
    report(rows, rows[:len(args.joints)], args)
    report_parts(rows, rows[:len(args.joints)])
    if ways:
        report_alternatives(ways)


def report(rows, chains, args):
    keys = [k for k in ("build", "first vm", "vm step", "first compiled", "compiled step", "dmoc")
            if k in rows[0]]
    print(f"load average {os.getloadavg()[0]:.2f}; h = {H}, {args.steps} steps a timed run")
    print("| model | n | L nodes | " + " | ".join(keys) + (" | verdict |" if args.dmoc else " |"))
    print("|---|---:|---:|" + "---:|" * len(keys) + ("---|" if args.dmoc else ""))
    for r in rows:
        cells = [f"{r[k] * 1e3:.3f} ms" if k.endswith("step") else f"{r[k]:.3f} s" for k in keys]
        if r["model"] == "mobile_arm (wheeled)":       # ratios over the fixed base's row
            r = {**r, "over": next(b for b in rows if b["model"] == "mobile_arm (fixed base)")}
        if "over" in r:      # the floating DMOC is another problem: no ratio
            cells = [c if k == "dmoc" and "floating" in r["model"] else f"{c} ({r[k] / r['over'][k]:.2f}x)"
                     for c, k in zip(cells, keys)]
        print(f"| {r['model']} | {r['n']} | {r['L nodes']} | " + " | ".join(cells)
              + (f" | {r['verdict']} |" if args.dmoc else " |"))
    if len(chains) >= 3:
        print("log-log slopes over the chains: " + ", ".join(
            f"{k} {slope(chains, k):.2f}" for k in ["L nodes", *keys]))


def report_parts(rows, chains):
    """The DMOC's iterations and the step's instructions (`--dmoc`, `--breakdown`), and their
    slopes over the chains and over those of 6 joints or more."""
    keys = [k for k in ("iterations", "per iteration", "g", "dg/dy", "dg/dy spatial", "update", "fast step",
                        "further update", "chord before", "Newton fast step") if any(k in r for r in rows)]
    if not keys:
        return
    print("| model | n | " + " | ".join(keys) + " |")
    print("|---|---:|" + "---:|" * len(keys))
    for r in rows:
        cells = ["–" if k not in r else f"{r[k] * 1e3:.2f} ms" if k == "per iteration"
                 else f"{r[k]} ({r['fast step'] / r[k]:.2f}x)" if k == "Newton fast step"
                 else str(r[k]) for k in keys]      # no breakdown of the step on the group
        print(f"| {r['model']} | {r['n']} | " + " | ".join(cells) + " |")
    large = [r for r in chains if r["n"] >= 6]
    for label, chosen in (("the chains", chains), ("the chains of 6+ joints", large)):
        if len(chosen) >= 2:
            print(f"log-log slopes over {label}: " + ", ".join(
                f"{k} {slope([r for r in chosen if k in r], k):.2f}" for k in keys
                if sum(k in r for r in chosen) >= 2))


if __name__ == "__main__":
    main()
