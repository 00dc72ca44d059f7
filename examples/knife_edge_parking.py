"""Parallel parking of a knife edge with DMOC: rest-to-rest from (0, 0, 0) to (0, 1, 0) in
4 s, m = J = 1, minimizing int |u|^2 dt.

The blade cannot slide sideways, so it must turn, drive, turn back and drive again. The
optimal controls are then replayed by the Dirac integrator (`dmoc.simulate`), which solves
the very same step residual, and must reproduce the optimized trajectory.

Run:  python examples/knife_edge_parking.py [--steps 100] [--out dmoc-output]
"""

import argparse
import pathlib

import dmoc
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.plotting import plot_controls, plot_path
from dmoc.problems import knife_edge_parking


def main(steps=100, out="dmoc-output"):
    problem = knife_edge_parking(steps)
    result = dmoc.optimize(problem)
    traj = result.trajectory
    print(format_summary(f"knife-edge parking, N = {steps}", optimization_summary(problem, result)))
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plot_path(traj, title="knife edge: optimal parking path").savefig(out / "knife_edge_parking_path.png", dpi=120)
    plot_controls(traj, names=["force along blade", "torque"],
                  title="knife edge: optimal controls").savefig(out / "knife_edge_parking_controls.png", dpi=120)
    traj.save(out / "knife_edge_parking.npz")
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--out", default="dmoc-output")
    args = parser.parse_args()
    main(args.steps, args.out)
