"""How IPOPT evaluates the NLP of a DMOC problem (consumer 2): the Functions it calls — the
objective, the constraints and the derivatives assembled from the terms (`separable`) —
interpreted by CasADi's virtual machine as the MX graph of mapped terms (the default),
expanded into one flat SX Function each (``expand=True``), or generated as C by CasADi and
compiled once per NLP and machine (``jit=True``), the library kept in the private
compiled-code cache that the simulator's steps use (`dmoc._util.compiled`, whose libraries
are loaded only when their bytes hash to their name and their Functions have the
signatures asked for). All three perform the same operations in the same order, so IPOPT
sees the same numbers; the flat and compiled forms cost less per evaluation and more to
build (benchmarks/peers.py resolve: "raw", "raw SX", "raw C").
"""

from ..._util.cache import BoundedCache
from ..._util.compiled import Library, compiler
from ...errors import InputError

_COMPILED = BoundedCache(16, "compiled_nlps")     # keyed by SeparableNLP.key: {name: Function}
_EXPANDED = BoundedCache(16, "expanded_nlps")     # keyed by SeparableNLP.key: {name: Function}


def nlp_functions(separable, *, expand=False, jit=False):
    """``{name: Function}`` for the ``cache`` option of ``casadi.nlpsol``.

    Parameters
    ----------
    separable : SeparableNLP
    expand, jit : bool
        `optimize`'s switches. `jit`: `separable`'s five Functions
        (``separable.functions()``) loaded from their compiled library, compiled first
        unless it is in the cache folder; else `expand`: the same five expanded to SX;
        else the assembled derivatives as they are (nlpsol builds f and g from the MX
        expressions itself).

    Raises
    ------
    InputError
        If `jit` and there is no C compiler.
    CompiledCodeError
        If the library can be neither compiled nor loaded safely (`Library.load` says why).
    """
    if jit:
        if compiler() is None:
            raise InputError("`jit=True` needs a C compiler: none found (set CC to one, or "
                             "leave jit=False for CasADi's virtual machine).")
        return _COMPILED.get(separable.key,
                             lambda: Library(separable.functions().values(), "dmoc_nlp").load())
    if expand:
        return _EXPANDED.get(separable.key,
                             lambda: {k: f.expand() for k, f in separable.functions().items()})
    return separable.derivatives()
