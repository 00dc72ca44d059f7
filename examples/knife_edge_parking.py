"""Parallel parking of a knife edge with DMOC: rest-to-rest from (0, 0, 0) to (0, 1, 0) in
4 s, m = J = 1, minimizing int |u|^2 dt.

The blade cannot slide sideways, so it must turn, drive, turn back and drive again. The
optimal controls are then replayed by the Dirac integrator (`dmoc.simulate`), which solves
the very same step residual, and must reproduce the optimized trajectory.

Run:  python examples/knife_edge_parking.py [--steps 100] [--out dmoc-output]
"""

import pathlib

import dmoc
from dmoc.cli import example_arguments
from dmoc.diagnostics import format_summary, optimization_summary
from dmoc.plotting import save_trajectory_plots
from dmoc.problems import knife_edge_parking


def main(steps=100, out="dmoc-output"):
    problem = knife_edge_parking(steps)
    result = dmoc.optimize(problem)
    print(format_summary(f"knife-edge parking, N = {steps}", optimization_summary(problem, result)))
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    save_trajectory_plots(result.trajectory, out, "knife_edge_parking",
                          control_names=["force along the blade", "torque"])
    result.trajectory.save(out / "knife_edge_parking.npz")
    return result


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__.splitlines()[0])))
