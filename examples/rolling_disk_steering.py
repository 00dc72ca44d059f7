"""
Steering a vertical rolling disk
================================

DMOC moves a vertical rolling disk rest-to-rest from the origin with heading 0 to x = 1,
y = 1, heading pi/2 in 4 s, with the rolling angle left free, minimizing the integral of
the squared norm of u. The disk rolls without slipping (two nonholonomic constraints); the controls are a
rolling torque and a steering torque. The optimal controls are replayed by
`dmoc.simulate`.

Run::

    python examples/rolling_disk_steering.py [--steps 100] [--out dmoc-output]

It prints the solver summary and the free final rolling angle, and writes the trajectory
(.npz), the plots and an animation of the disk seen from above, with a mark on its rim
(.gif), into the output folder.
"""

# The gallery's thumbnail is the path (the figures are shown in file-name order:
# constraint, controls, energy, path, states, then the animation).
# sphinx_gallery_thumbnail_number = 4

import dmoc
from dmoc.cli import example_arguments
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.problems import rolling_disk_steering


def main(steps=100, out="dmoc-output"):
    problem = rolling_disk_steering(steps)
    result = dmoc.optimize(problem)
    print(format_summary(f"rolling-disk steering, N = {steps}", optimization_summary(problem, result)))
    traj = result.trajectory
    print(f"  final rolling angle      {traj.q[-1, 2]:.6f} rad (free)")
    dmoc.plotting.save_trajectory_plots(
        traj, out, "rolling_disk_steering", problem=problem,
        control_names=["rolling torque", "steering torque"], heading=3)
    system = problem.disc.system        # its disk and rim mark, true to size (R = 1 m)
    dmoc.animation.animate(traj, f"{out}/rolling_disk_steering.gif", bodies=system.bodies,
                           goal=problem.q_goal, units=system.units, frames=40)
    traj.save(f"{out}/rolling_disk_steering.npz")
    return result


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
