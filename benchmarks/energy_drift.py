"""Energy drift of the discrete flow, by system and rule: the fitted drift rate
(`dmoc.diagnostics.energy_drift_rate`, dE/dt relative to max|E|) and the relative change
over the run, for the knife edge on an incline, the rolling disk, and the circling car
(`dmoc.systems.car`, steering spring at 0.6 rad, started at 0.5 rad and 5 m/s) with its
centre of mass on the rear axle (b = 0) and 0.3 m ahead of it.

    python benchmarks/energy_drift.py [--duration 1000]
"""

import argparse

import numpy as np

import dmoc


def cases():
    yield "knife edge, incline 0.3", dmoc.systems.knife_edge(incline=0.3), [0, 0, 0], [1.0, 0, 1.0]
    yield "rolling disk", dmoc.systems.rolling_disk(), [0, 0, 0, 0], [1.0, 0.0, 1.0, 0.5]
    for b in (0.0, 0.3):
        car = dmoc.systems.car(com_offset=b, steering_stiffness=50.0, steering_rest=0.6)
        yield f"car, b = {b} m", car, [0, 0, 0, 0.5], [5.0, 0, 5.0 * np.tan(0.5) / 2.7, 0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=1000.0)
    args = parser.parse_args(argv)
    print(f"{'system':26s} {'rule':9s} {'h':>7s} {'rate (1/s)':>11s} {'change':>10s}")
    for name, system, q0, v0 in cases():
        for rule, h in (("midpoint", 0.05), ("midpoint", 0.025), ("lobatto3", 0.1), ("lobatto3", 0.05)):
            disc = dmoc.discretize(system, h, rule)
            traj = dmoc.simulate(disc, q0=q0, v0=v0, steps=round(args.duration / h)).trajectory
            E = dmoc.diagnostics.energy(disc, traj)
            rate = dmoc.diagnostics.energy_drift_rate(disc, traj)
            print(f"{name:26s} {rule:9s} {h:7.4g} {rate:11.2e} {(E[-1] - E[0]) / abs(E[0]):10.2e}")


if __name__ == "__main__":
    main()
