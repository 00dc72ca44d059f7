"""What the benchmarks share about dmoc's solver cache: emptying it, so that a timed solve
builds its solver anew as the baselines do. It lives in dmoc.ipopt, or in dmoc.optimize
on older checkouts (benchmarks compare checkouts through PYTHONPATH)."""

import importlib
import importlib.util

MODULES = [m for m in (importlib.import_module(name) for name in ("dmoc.optimize", "dmoc.ipopt")
                       if importlib.util.find_spec(name)) if hasattr(m, "_SOLVERS")]


def forget_solvers():
    """Empty dmoc's solver cache (a new cache of the same size)."""
    for module in MODULES:
        module._SOLVERS = type(module._SOLVERS)(module._SOLVERS.maxsize)
