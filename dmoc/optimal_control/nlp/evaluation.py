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

By default (``jit=None``) a structure is compiled in the background once it is re-solved
(`compiled_when_ready`): the solves go on in the virtual machine until the library is
loaded, then on the compiled Functions, which give the same bits.
"""

from ..._util.cache import BoundedCache
from ..._util.compiled import Background, Library, compiler
from ...errors import InputError

_COMPILED = BoundedCache(16, "compiled_nlps")     # keyed by SeparableNLP.key: {name: Function}
_EXPANDED = BoundedCache(16, "expanded_nlps")     # keyed by SeparableNLP.key: {name: Function}
# keyed by SeparableNLP.key: the `Background` compile of that NLP's library
_BACKGROUND = BoundedCache(16, "background_compiles")


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


def compiled_when_ready(separable):
    """True when `separable`'s compiled Functions are loaded in this process (then
    ``nlp_functions(separable, jit=True)`` returns them at once), else False: the first
    call starts compiling (or loading from the cache folder) the library of
    `nlp_functions` with ``jit=True`` in a background thread (`compiled.Background`), and
    a later call returns True once that has ended. False for good without a C compiler
    or when the library could not be compiled or loaded safely (the virtual machine
    computes the same bits)."""
    if separable.key in _COMPILED:
        return True
    if compiler() is None:
        return False
    loaded = _BACKGROUND.get(separable.key, lambda: _started(separable)).functions
    if loaded is None:
        return False
    _COMPILED.get(separable.key, lambda: loaded)
    return True


def _started(separable):
    """The `Background` compile of `separable`'s library, its Functions made here (the
    serialization of the cache key is the thread's work)."""
    functions = list(separable.functions().values())
    return Background(lambda: Library(functions, "dmoc_nlp").load())
