"""What the benchmarks share about dmoc's solver: emptying its cache, so that a timed solve
builds its solver anew as the baselines do, and passing dmoc's switches (``expand``,
``reuse_solver``) as keywords of `optimize` where the checkout has them, inside `options`
on older checkouts. ``dmoc.clear_caches("solvers")`` (and "row_sums") where it exists;
checkouts without it (benchmarks compare checkouts through PYTHONPATH) kept the cache as
``_SOLVERS`` in dmoc.ipopt or dmoc.optimize."""

import importlib
import importlib.util
import inspect

import dmoc


def forget_solvers():
    """Empty dmoc's solver cache."""
    if hasattr(dmoc, "clear_caches"):
        # the row sums of the data tolerances are built with the solver (checkouts from
        # before them have no such cache)
        from dmoc._util.cache import cache_names
        names = cache_names()
        dmoc.clear_caches("solvers", *(["row_sums"] if "row_sums" in names else []))
        return
    for name in ("dmoc.optimize", "dmoc.ipopt"):
        module = importlib.import_module(name) if importlib.util.find_spec(name) else None
        if hasattr(module, "_SOLVERS"):
            module._SOLVERS = type(module._SOLVERS)(module._SOLVERS.maxsize)


SWITCH_KEYWORDS = "expand" in inspect.signature(dmoc.optimize).parameters


def optimize(problem, *, options, **switches):
    """``dmoc.optimize(problem, options=options, **switches)``, the switches inside
    `options` on checkouts whose `optimize` does not take them as keywords."""
    if SWITCH_KEYWORDS:
        return dmoc.optimize(problem, options=options, throw=False, **switches)
    return dmoc.optimize(problem, options={**switches, **options}, throw=False)
