"""Steering a vertical rolling disk with DMOC: rest-to-rest from the origin, heading 0, to
x = 1, y = 1, heading pi/2 in 4 s, with the rolling angle left free, minimizing int |u|^2.

The disk rolls without slipping (two nonholonomic constraints); the controls are a rolling
torque and a steering torque. The optimal controls are replayed by `dmoc.simulate`.

Run:  python examples/rolling_disk_steering.py [--steps 100] [--out dmoc-output]
"""

import argparse
import pathlib

import dmoc
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.plotting import plot_controls, plot_path
from dmoc.problems import rolling_disk_steering


def main(steps=100, out="dmoc-output"):
    problem = rolling_disk_steering(steps)
    result = dmoc.optimize(problem)
    traj = result.trajectory
    print(format_summary(f"rolling-disk steering, N = {steps}", optimization_summary(problem, result)))
    print(f"  final rolling angle      {traj.q[-1, 2]:.6f} rad (free)")
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plot_path(traj, title="rolling disk: optimal path").savefig(out / "rolling_disk_steering_path.png", dpi=120)
    plot_controls(traj, names=["rolling torque", "steering torque"],
                  title="rolling disk: optimal controls").savefig(out / "rolling_disk_steering_controls.png", dpi=120)
    traj.save(out / "rolling_disk_steering.npz")
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--out", default="dmoc-output")
    args = parser.parse_args()
    main(args.steps, args.out)
