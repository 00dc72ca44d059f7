"""What the benchmarks share about dmoc's solver cache: emptying it, so that a timed solve
builds its solver anew as the baselines do. ``dmoc.clear_caches("solvers")`` where it exists;
checkouts without it (benchmarks compare checkouts through PYTHONPATH) kept the cache as
``_SOLVERS`` in dmoc.ipopt or dmoc.optimize."""

import importlib
import importlib.util

import dmoc


def forget_solvers():
    """Empty dmoc's solver cache."""
    if hasattr(dmoc, "clear_caches"):
        dmoc.clear_caches("solvers")
        return
    for name in ("dmoc.optimize", "dmoc.ipopt"):
        module = importlib.import_module(name) if importlib.util.find_spec(name) else None
        if hasattr(module, "_SOLVERS"):
            module._SOLVERS = type(module._SOLVERS)(module._SOLVERS.maxsize)
