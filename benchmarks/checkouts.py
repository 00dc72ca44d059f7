"""Which dmoc each checkout of a `--checkouts` benchmark imports (the benchmarks that time
several checkouts in one run start a child per checkout with PYTHONPATH set to it)."""

import os
import pathlib
import subprocess
import sys
import tempfile


def imported_dmoc(checkout):
    """The path of the dmoc package a child process imports with PYTHONPATH = `checkout`,
    run outside the checkouts (`python -m` would put the working folder first)."""
    return subprocess.run([sys.executable, "-c", "import dmoc; print(dmoc.__file__)"],
                          env={**os.environ, "PYTHONPATH": checkout}, cwd=tempfile.gettempdir(),
                          capture_output=True, text=True, check=True).stdout.strip()


def add_checkouts(parser):
    """`parser`'s option ``--checkouts DIR ...``: the dmoc checkouts a benchmark compares,
    each on PYTHONPATH in turn (default: the checkout holding this folder)."""
    parser.add_argument("--checkouts", nargs="+", default=[str(pathlib.Path(__file__).resolve().parents[1])],
                        help="dmoc checkouts to compare, each on PYTHONPATH in turn (default: this one)")
