"""The ``dmoc`` command (also ``python -m dmoc``), a thin front end over the public API:
``dmoc systems`` lists the built-in systems, ``dmoc simulate SYSTEM`` runs the Dirac
integrator, ``dmoc optimize SYSTEM`` solves a DMOC problem, ``dmoc demo`` runs both on the
built-ins. SYSTEM is a built-in name or ``path/to/file.py:factory``, a function in that
file (which is imported, so its top-level code runs) returning a system, or a whole
problem.

Exit codes: 0 success; 1 the solver failed (its status is printed and what was computed
is written); 2 a bad argument (one line naming it); 130 stopped by Ctrl-C (what the
solver had computed is written, if it got that far).
"""

import argparse
import importlib.metadata
import sys

from ..discrete import RULES
from . import commands, demo, registry
from .arguments import Parser, UsageError, positive_float, positive_int

__all__ = ["main", "example_arguments"]


def _version():
    try:
        return importlib.metadata.version("dmoc")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed)"


def _plain(text):
    """A docstring as ``--help`` shows it: without reST's double backticks."""
    return text.replace("``", "")


SIMULATE = """Simulate SYSTEM with the Dirac integrator: N steps of h = T/N from --start and
--velocity, with the controls of --controls (zero without). Given the table NAME.csv
that dmoc optimize --out wrote, --controls also gives the step h and the start (q_0, p_0)
of that run, so the replay is that optimum."""

OPTIMIZE = """Solve a DMOC problem with IPOPT: from --start to --goal (at rest unless --velocity
gives the start velocity), minimizing the integral of |u|^2 over T, within the bounds of
--control-min/--control-max and --state-min/--state-max, with T free in --free-time.
A file's factory may return a whole OptimalControlProblem (its costs, bounds, path
constraints and final time); then --start, --goal and --velocity change its boundary data
and the options it states itself are refused."""


def _common(sub, steps, start):
    """Options shared by simulate and optimize; `steps` and `start` are the defaults the
    help of --steps and --start states."""
    sub.add_argument("system", metavar="SYSTEM",
                     help=f"{', '.join(registry.BUILT_IN)} (see `dmoc systems`), or "
                     f"path/to/file.py:factory (the file is imported, which runs it)")
    sub.add_argument("--param", action="append", metavar="NAME=VALUE",
                     help="a parameter of the factory, e.g. --param mass=2 (repeatable)")
    sub.add_argument("--start", metavar="Q", help=f"start configuration, comma-separated "
                     f"(default: {start})")
    sub.add_argument("--steps", type=positive_int, metavar="N", help=f"number of steps N "
                     f"(default: {steps})")
    sub.add_argument("--rule", choices=tuple(RULES), help="quadrature rule of the discrete "
                     "Lagrangian (default: midpoint)")
    sub.add_argument("--variant", choices=("+", "-"),
                     help="(+) equations (37) or (-) equations (41) (default: +)")
    sub.add_argument("--heading", metavar="NAME", help="the coordinate holding the heading, "
                     "drawn as arrows in the path plot and the GIF (default: the built-in's)")
    sub.add_argument("--out", metavar="DIR", help="write trajectory (.npz, .csv), summary "
                     "(.json) and plots (.png) into DIR")
    sub.add_argument("--no-plots", action="store_true", help="write no plots (with --out)")
    sub.add_argument("--animate", action="store_true", help="also write a GIF (needs --out)")
    sub.add_argument("--verbose", action="store_true", help="more output (IPOPT's iteration log)")


def build_parser():
    """The argument parser of the ``dmoc`` command."""
    parser = Parser(prog="dmoc", description=_plain(__doc__))
    parser.add_argument("--version", action="version", version=f"dmoc {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser("systems", help="list the built-in systems, their parameters and defaults")
    sim = sub.add_parser("simulate", help="simulate a system with the Dirac integrator",
                         description=SIMULATE)
    _common(sim, "1000, or the rows of --controls",
            "the table of --controls, the problem's, the built-in's, or 0")
    sim.add_argument("--velocity", metavar="V", help="start velocity in Delta_Q, comma-separated "
                     "(default: the table of --controls gives the start momentum; else the "
                     "problem's, the built-in's, or 0)")
    sim.add_argument("--duration", type=positive_float, metavar="T", help="final time T, "
                     "h = T/N (default: 10, or the times of the table of --controls)")
    sim.add_argument("--controls", metavar="FILE", help="controls u_k, one row per step (.npy, "
                     "or .csv/.txt with an optional header), or the NAME.csv of optimize")
    opt = sub.add_parser("optimize", help="solve a DMOC problem with IPOPT", description=OPTIMIZE)
    _common(opt, "100", "the problem's, the built-in's, or 0")
    opt.add_argument("--goal", metavar="Q", help="goal configuration; entries 'free' are free "
                     "(default: the problem's or the built-in's)")
    opt.add_argument("--velocity", metavar="V", help="start velocity; entries 'free' are free "
                     "(default: the problem's, else at rest)")
    opt.add_argument("--duration", type=positive_float, metavar="T", help="final time T, "
                     "h = T/N; with --free-time the guess's (default: 4, or the middle of "
                     "--free-time)")
    opt.add_argument("--free-time", metavar="TMIN,TMAX", help="free final time in [TMIN, TMAX]")
    for which, names in (("control", "u"), ("state", "q"), ("velocity", "v")):
        for end, word in (("min", "lower"), ("max", "upper")):
            opt.add_argument(f"--{which}-{end}", metavar=names.upper(),
                             help=f"{word} bounds of {names}, comma-separated; entries 'none' "
                             f"are unbounded" + (" (at every knot and stage node)"
                                                 if which == "velocity" else ""))
    opt.add_argument("--max-iter", type=positive_int, default=1000, metavar="K",
                     help="IPOPT iteration limit (default: 1000)")
    dem = sub.add_parser("demo", help="simulate and optimize the built-in systems; write a summary and plots")
    dem.add_argument("--out", default="dmoc-output", metavar="DIR", help="output folder (default: dmoc-output)")
    dem.add_argument("--steps", type=positive_int, default=1000, metavar="N",
                     help="simulation steps (default: 1000)")
    dem.add_argument("--opt-steps", type=positive_int, default=100, metavar="N",
                     help="DMOC steps (default: 100)")
    return parser


def main(argv=None):
    """Entry point of the ``dmoc`` command; returns the exit code (0, 1, 2 or 130)."""
    try:
        args = build_parser().parse_args(argv)
        if args.command == "systems":
            print(registry.describe())
            return 0
        run = {"simulate": commands.run_simulate, "optimize": commands.run_optimize,
               "demo": demo.run_demo}[args.command]
        return run(args)
    except UsageError as err:
        print(f"dmoc: error: {err}", file=sys.stderr)
        return 2
    except SystemExit as done:          # --help and --version
        return done.code
    except KeyboardInterrupt:           # outside a solve (those return their results)
        print("dmoc: interrupted (Ctrl-C) before the results were written; --out is as it "
              "was", file=sys.stderr)
        return 130


def example_arguments(description, argv=None):
    """Parse the options shared by the example scripts: ``--steps`` and ``--out``.

    `description` (the script's docstring) is shown in full by ``--help``.
    """
    parser = argparse.ArgumentParser(description=description,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=positive_int, default=100, help="DMOC steps (default: 100)")
    parser.add_argument("--out", default="dmoc-output", help="output folder (default: dmoc-output)")
    return parser.parse_args(argv)
