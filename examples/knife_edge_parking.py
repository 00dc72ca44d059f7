"""
Parallel parking of a knife edge
================================

DMOC moves a knife edge rest-to-rest from (x, y, theta) = (0, 0, 0) to (0, 1, 0) in 4 s,
with m = J = 1, minimizing the integral of the squared norm of u. The blade cannot slide sideways, so it
must turn, drive, turn back and drive again. The optimal controls are then replayed by the
Dirac integrator (`dmoc.simulate`), which solves the very same step residual, and must
reproduce the optimized trajectory.

Run::

    python examples/knife_edge_parking.py [--steps 100] [--out dmoc-output]

It prints the solver summary and writes the trajectory (.npz), the plots (path with
headings, goal and the blade the system declares at a few poses, states, controls,
constraint violation, energy balance) and an animation of the blade (.gif) into the output
folder.
"""

# The gallery's thumbnail is the path (the figures are shown in file-name order:
# constraint, controls, energy, path, states, then the animation).
# sphinx_gallery_thumbnail_number = 4

import dmoc
from dmoc.cli import example_arguments
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.problems import knife_edge_parking


def main(steps=100, out="dmoc-output"):
    problem = knife_edge_parking(steps)
    result = dmoc.optimize(problem)
    print(format_summary(f"knife-edge parking, N = {steps}", optimization_summary(problem, result)))
    traj = result.trajectory
    dmoc.plotting.save_trajectory_plots(
        traj, out, "knife_edge_parking", problem=problem,
        control_names=["force along the blade", "torque"], heading=2)
    system = problem.disc.system        # its blade (`system.bodies`) is drawn at every frame
    dmoc.animation.animate(traj, f"{out}/knife_edge_parking.gif", bodies=system.bodies,
                           goal=problem.q_goal, units=system.units, frames=40)
    traj.save(f"{out}/knife_edge_parking.npz")
    return result


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
