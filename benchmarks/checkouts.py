"""Which dmoc each checkout of a `--checkouts` benchmark imports (the benchmarks that time
several checkouts in one run start a child per checkout with PYTHONPATH set to it)."""

import os
import subprocess
import sys
import tempfile


def imported_dmoc(checkout):
    """The path of the dmoc package a child process imports with PYTHONPATH = `checkout`,
    run outside the checkouts (`python -m` would put the working folder first)."""
    return subprocess.run([sys.executable, "-c", "import dmoc; print(dmoc.__file__)"],
                          env={**os.environ, "PYTHONPATH": checkout}, cwd=tempfile.gettempdir(),
                          capture_output=True, text=True, check=True).stdout.strip()
