"""
Tracking a plan: a tracking MPC and LQR gains on a heavier knife edge
=====================================================================

A plan parks a knife edge from (x, y, theta) = (0, 0, 0) at (0, 1, 0) in 4 s (40 steps
of h = 0.1 s, minimizing the integral of the squared norm of u). The plant is 20 % heavier
than the model, in mass and inertia. Three ways to follow the plan, each simulated by
`dmoc.simulate` on the plant from the plan's start:

- open loop: the plan's controls as they are;
- time-varying LQR: the gains of `dmoc.tvlqr` from the exact linearization of the discrete
  step along the plan, u_k = u*_k - K_k (x_k - x*_k) with x = (q, p);
- a tracking MPC: `dmoc.MPC(problem, references=...)` over a horizon of 10 steps whose
  costs read the plan's configurations (per knot) and controls (per step) as parameters,
  moved on by one step at every step (no new NLP), the feed-forward zero after the plan.

Run::

    python examples/mpc_tracking.py [--steps 50] [--out dmoc-output]

(`--steps`: closed-loop steps, at least the plan's 40.) It prints each loop's distance
to the plan's end and draws the three paths with the plan.
"""

import pathlib

import casadi as ca
import matplotlib.pyplot as plt
import numpy as np

import dmoc
from dmoc.cli import example_arguments
from dmoc.problems import knife_edge_parking

PLAN_STEPS = 40


def main(steps=50, out="dmoc-output", horizon=10):
    parking = knife_edge_parking(PLAN_STEPS)
    plan = dmoc.optimize(parking).trajectory
    plant = dmoc.discretize(dmoc.systems.knife_edge(mass=1.2, inertia=1.2), plan.h)
    steps = max(steps, PLAN_STEPS)
    at_rest = np.vstack([plan.u, np.zeros((steps - PLAN_STEPS, 2))])    # the feed-forward after the plan
    gains = dmoc.tvlqr(parking.disc, plan, np.diag([1e3] * 3 + [1.0] * 3), np.eye(2), Q_N=1e4 * np.eye(6))
    tracking = dmoc.OptimalControlProblem(
        parking.disc, horizon, q_start=plan.q[0], q_goal=[None] * 3, v_goal=[None] * 3,
        parameters={"q_ref": plan.q[:horizon + 1], "u_ref": plan.u[:horizon]},
        running_cost=lambda q, v, u, w: 1e4 * ca.sumsqr(q - w["q_ref"]) + ca.sumsqr(u - w["u_ref"]),
        terminal_cost=lambda q, v, w: 1e4 * ca.sumsqr(q - w["q_ref"]))
    controller = dmoc.MPC(tracking, references={"q_ref": plan.q, "u_ref": at_rest})
    laws = {"open loop": lambda k, q, p: at_rest[k],
            "LQR gains": lambda k, q, p: gains.control(k, q, p) if k < PLAN_STEPS else at_rest[k],
            "tracking MPC": lambda k, q, p: controller.step(q, p=p)}
    paths = {}
    for name, law in laws.items():
        paths[name] = closed_loop(plant, plan, law, steps)
        print(f"{name:13s} ends {1e3 * np.linalg.norm(paths[name].q[-1] - plan.q[-1]):7.1f} mm "
              f"from the plan's end")
    iterations = [r.iterations for r in controller.log]
    print(f"tracking MPC: {len(iterations)} steps, IPOPT iterations per warm step "
          f"{int(np.median(iterations[1:]))} (median), every solve succeeded: "
          f"{all(r.success for r in controller.log)}")
    draw(plan, paths, pathlib.Path(out))
    return plan, paths, controller.log


def closed_loop(plant, plan, law, steps):
    """The plant from the plan's start, the controls of step k given by law(k, q_k, p_k)."""
    q, p, states, momenta, controls = plan.q[0], plan.p[0], [plan.q[0]], [plan.p[0]], []
    for k in range(steps):
        u = law(k, q, p)
        run = dmoc.simulate(plant, q0=q, p0=p, steps=1, controls=u[None], jit=False)
        q, p = run.trajectory.q[-1], run.trajectory.p[-1]
        states.append(q), momenta.append(p), controls.append(u)
    return dmoc.Trajectory(plan.h * np.arange(steps + 1), states, momenta, None, controls, plan.h, "+")


def draw(plan, paths, out):
    """The plan and the three closed loops in the plane, as a PNG file."""
    out.mkdir(parents=True, exist_ok=True)
    fig = dmoc.plotting.plot_path(plan, heading=2, goal=plan.q[-1], name="plan", color="0.5",
                                  title="Following a plan on a plant 20 % heavier")
    ax = fig.axes[0]
    for (name, path), color in zip(paths.items(), ("C3", "C2", "C0")):
        ax.plot(path.q[:, 0], path.q[:, 1], color=color, label=name)
    ax.legend(loc="best")
    fig.savefig(out / "mpc_tracking_paths.png", dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
