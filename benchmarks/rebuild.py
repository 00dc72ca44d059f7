"""Benchmark: the cost of simulating again at another step h, against the first call.

The step residual and the compiled Dirac step depend on the system, the rule and the
formulation only (h is an input), so a second `discretize` + `simulate` at a new h reuses
them: "same system" passes the same MechanicalSystem again (a free-time replay, a refined
grid), "equal system" builds it anew from the same data. Each case runs in a fresh
process (the first call must build everything); prints the wall times and their ratios.

    python benchmarks/rebuild.py
    PYTHONPATH=/path/to/other/checkout python benchmarks/rebuild.py   # compare checkouts
"""

import argparse
import os
import platform
import subprocess
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402

import dmoc  # noqa: E402

CASES = {
    "knife-edge": (lambda: dmoc.systems.knife_edge(incline=0.2), [0.0, 0.0, 0.0], [1.0, 0.0, 1.0]),
    "rolling-disk": (dmoc.systems.rolling_disk, [0.0] * 4, [1.0, 0.0, 1.0, 0.5]),
}
STEPS = 1000


def timed_run(system, q0, v0, h, variant):
    tic = time.perf_counter()
    disc = dmoc.discretize(system, h)
    dmoc.simulate(disc, q0=q0, v0=v0, steps=STEPS, variant=variant)
    return time.perf_counter() - tic


def case(name, variant):
    """(first, same system at a new h, equal system at another new h) wall seconds."""
    make, q0, v0 = CASES[name]
    system = make()
    return (timed_run(system, q0, v0, 0.01, variant), timed_run(system, q0, v0, 0.005, variant),
            timed_run(make(), q0, v0, 0.0025, variant))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) == 2:              # one case, in this fresh process
        print(*case(*argv))
        return
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args(argv)
    print(f"dmoc from {os.path.dirname(dmoc.__file__)}; python {platform.python_version()}, "
          f"casadi {ca.__version__}; {STEPS} steps, midpoint rule, one process per row")
    head = (f"{'system':<14}{'variant':>8}{'first [s]':>11}{'same sys [s]':>14}{'ratio':>7}"
            f"{'equal sys [s]':>15}{'ratio':>7}")
    print(head + "\n" + "-" * len(head))
    for name in CASES:
        for variant in ("+", "-"):
            out = subprocess.run([sys.executable, __file__, name, variant], check=True,
                                 capture_output=True, text=True).stdout
            first, same, equal = map(float, out.split())
            print(f"{name:<14}{variant:>8}{first:>11.4f}{same:>14.4f}{same / first:>7.3f}"
                  f"{equal:>15.4f}{equal / first:>7.3f}")


if __name__ == "__main__":
    main()
