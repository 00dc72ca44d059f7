"""
Model predictive control of a knife edge
========================================

A receding-horizon controller (`dmoc.MPC`) parks a knife edge from (x, y, theta) =
(0, 0, 0) at (0, 1, 0). At every step of h = 0.1 s it solves the parking problem over the
next 30 steps (3 s, minimizing the integral of the squared norm of u, at rest at the
goal) from the state it measures, and applies the first step's controls. The plant is simulated by
`dmoc.simulate` with a model error, a blade 10 % heavier than the controller's model, and
a disturbance: at t = 1 s a kick adds momentum along the blade and about the vertical
axis. The controller measures the plant's configuration and velocity with Gaussian noise
(1 mm and 1 mrad, 1e-3 on the velocity): no measured velocity satisfies the blade's
constraint exactly, so the controller's measurement policy (``measurement="project"``, the
default) projects each onto the allowed velocities before the solve starts from it, and
records the correction. Each solve is warm-started from the previous plan shifted by one
step on IPOPT's kept solver.

Run::

    python examples/mpc_knife_edge.py [--steps 60] [--out dmoc-output]

(`--steps`: closed-loop steps.) It prints the per-step solver record and draws the
closed-loop path with the first plan, and the per-step solve times.
"""

import pathlib

import matplotlib.pyplot as plt
import numpy as np

import dmoc
from dmoc.cli import example_arguments
from dmoc.problems import knife_edge_parking

KICK_STEP, KICK = 10, 0.3        # at t = 1 s: momentum 0.3 along the blade and about z
NOISE = 1e-3                     # standard deviation of the sensors, on q and on v


def main(steps=60, out="dmoc-output", horizon=30):
    problem = knife_edge_parking(horizon, duration=0.1 * horizon)
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.1, inertia=1.0), problem.disc.h)
    controller = dmoc.MPC(problem)
    rng = np.random.default_rng(0)
    q, p = np.zeros(3), np.zeros(3)
    states, momenta, controls = [q], [p], []
    for k in range(steps):
        v = p / np.array([1.1, 1.1, 1.0])        # the plant's velocity, p = M v
        u = controller.step(q + NOISE * rng.normal(size=3), v=v + NOISE * rng.normal(size=3))
        if k == KICK_STEP:
            p = p + KICK * np.array([np.cos(q[2]), np.sin(q[2]), 1.0])
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        states.append(q), momenta.append(p), controls.append(u)
        if k == 0:
            first_plan = controller.plan.trajectory
    closed_loop = dmoc.Trajectory(problem.disc.h * np.arange(steps + 1), states, momenta, None,
                                  controls, problem.disc.h, "+")
    log = controller.log
    print("step  status            iterations  solve [ms]  warm   corrected     |v - v_measured|")
    for k, record in enumerate(log):
        print(f"{k:4d}  {record.status:16s}  {record.iterations:10d}  "
              f"{1e3 * record.solve_time:10.1f}  {record.warm_start!s:5}  "
              f"{','.join(record.corrected) or '-':12s}  {record.v_correction:.1e}")
    print(f"final state {np.round(q, 4).tolist()}, goal {problem.q_goal.tolist()}")
    draw(closed_loop, first_plan, log, problem.q_goal, pathlib.Path(out))
    return closed_loop, log


def draw(closed_loop, first_plan, log, goal, out):
    """The closed-loop path (with the first plan) and the per-step times, as PNG files."""
    out.mkdir(parents=True, exist_ok=True)
    fig = dmoc.plotting.plot_path(closed_loop, heading=2, goal=goal,
                                  title="MPC: closed loop (plant 10 % heavier, noisy sensors, kick at t = 1 s)")
    ax = fig.axes[0]
    ax.plot(first_plan.q[:, 0], first_plan.q[:, 1], "--", color="gray", label="first plan")
    kick = closed_loop.q[KICK_STEP + 1]
    ax.plot(kick[0], kick[1], "rx", markersize=10, label="kick")
    ax.legend(loc="best")
    fig.savefig(out / "mpc_knife_edge_path.png", dpi=80)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    times = 1e3 * np.array([[r.solve_time, r.step_time] for r in log])
    ax.semilogy(times[:, 1], "o-", label="whole step")
    ax.semilogy(times[:, 0], ".-", label="IPOPT")
    ax.set_xlabel("closed-loop step")
    ax.set_ylabel("time [ms]")
    ax.set_title("per-step solve times (step 0: cold, builds the solver)")
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(out / "mpc_knife_edge_solve_times.png", dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
