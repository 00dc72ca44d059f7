"""Steering a vertical rolling disk with DMOC: rest-to-rest from the origin, heading 0, to
x = 1, y = 1, heading pi/2 in 4 s, with the rolling angle left free, minimizing int |u|^2.

The disk rolls without slipping (two nonholonomic constraints); the controls are a rolling
torque and a steering torque. The optimal controls are replayed by `dmoc.simulate`.

Run:  python examples/rolling_disk_steering.py [--steps 100] [--out dmoc-output]
"""

import pathlib

import dmoc
from dmoc.cli import example_arguments
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.plotting import save_trajectory_plots
from dmoc.problems import rolling_disk_steering


def main(steps=100, out="dmoc-output"):
    problem = rolling_disk_steering(steps)
    result = dmoc.optimize(problem)
    print(format_summary(f"rolling-disk steering, N = {steps}", optimization_summary(problem, result)))
    print(f"  final rolling angle      {result.trajectory.q[-1, 2]:.6f} rad (free)")
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    save_trajectory_plots(result.trajectory, out, "rolling_disk_steering",
                          control_names=["rolling torque", "steering torque"])
    result.trajectory.save(out / "rolling_disk_steering.npz")
    return result


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__.splitlines()[0])))
