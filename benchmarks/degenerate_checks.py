"""Benchmark: what the test of the alternating mode (`dmoc.principle.parasitic`) costs when
`step_residual` first meets a degenerate Lagrangian and a rule, against building the step
residual itself and against simulating 1000 steps in CasADi's virtual machine, all timed
in this run (best of `--repeat`, caches cleared before each).

    python benchmarks/degenerate_checks.py
"""

import argparse
import platform
import time
import warnings

import numpy as np

import dmoc
from dmoc.principle.parasitic import alternating_growth
from dmoc.principle.residual import StepResidual
from dmoc.systems import point_vortices


def one_form():
    """L = a(q).v - |q|^2/2, a = (-y/2, x/2 + x^3/3)."""
    return dmoc.MechanicalSystem(
        lambda q, v: -q[1] / 2 * v[0] + (q[0] / 2 + q[0] ** 3 / 3) * v[1] - (q[0] ** 2 + q[1] ** 2) / 2, 2)


CASES = {"one-form": one_form, "vortex pair": lambda: point_vortices([1.0, 2.0]),
         "three vortices": lambda: point_vortices([1.0, 2.0, -0.7])}


def best_of(repeat, run):
    times = []
    for _ in range(repeat):
        dmoc.clear_caches()
        tic = time.perf_counter()
        run()
        times.append(time.perf_counter() - tic)
    return min(times)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    print(f"# {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"best of {args.repeat}")
    print("| system | rule | residual [s] | test [s] | test/residual | test/simulate 1000 steps |")
    print("|---|---|---|---|---|---|")
    for name, make in CASES.items():
        for rule in ("midpoint", "trapezoid", "lobatto3", "lobatto4"):
            system = make()
            disc = dmoc.discretize(system, 0.1, rule)
            residual = best_of(args.repeat, lambda: StepResidual(disc))
            R = StepResidual(disc)
            test = best_of(args.repeat, lambda: alternating_growth(R, system, disc.h))
            q0 = np.linspace(-0.9, 0.8, system.n)
            p0 = np.array(system.momentum(q0, np.zeros(system.n))).ravel()
            dmoc.simulate(disc, q0=q0, p0=p0, steps=2, jit=False)
            run = best_of(args.repeat, lambda: dmoc.simulate(disc, q0=q0, p0=p0, steps=1000, jit=False))
            print(f"| {name} | {rule} | {residual:.3f} | {test:.3f} | {test / residual:.1f} | "
                  f"{test / run:.2f} |")


if __name__ == "__main__":
    main()
