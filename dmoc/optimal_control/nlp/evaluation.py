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

By default (``jit=None``) a structure is compiled in the background once its warm
re-solves have spent COMPILE_AFTER_SECONDS in IPOPT (`compiled_when_ready`): the solves go
on in the virtual machine until the library is loaded, then on the compiled Functions,
which give the same bits.
"""

from ..._util.cache import BoundedCache
from ..._util.compiled import Background, Library, compiler
from ...errors import InputError

_COMPILED = BoundedCache(16, "compiled_nlps")     # keyed by SeparableNLP.key: {name: Function}
_EXPANDED = BoundedCache(16, "expanded_nlps")     # keyed by SeparableNLP.key: {name: Function}
# keyed by SeparableNLP.key: the `Background` compile of that NLP's library
_BACKGROUND = BoundedCache(16, "background_compiles")
# keyed by SeparableNLP.key: [the seconds IPOPT spent on warm re-solves of it uncompiled]
_SPENT = BoundedCache(64, "re_solve_seconds")

# The seconds of IPOPT (`stats["ipopt_time"]`) a structure's warm re-solves spend in the
# virtual machine before its library is compiled in the background: 10-40 re-solves of the
# problems of benchmarks/peers.py (2.5-10 ms each), so that a script that re-solves a
# structure a few times (a test, a study of a few goals) starts no compiler (1-3 s of a
# core), and a loop of re-solves or MPC steps is compiled within its first second.
COMPILE_AFTER_SECONDS = 0.1


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


def compiled_when_ready(separable, warm):
    """True when `separable`'s compiled Functions are loaded in this process (then
    ``nlp_functions(separable, jit=True)`` returns them at once), else False. A `warm`
    re-solve (a start from an optimum of the same structure) asks for them: once such
    re-solves have spent COMPILE_AFTER_SECONDS in IPOPT (`spent`), the library of
    `nlp_functions` with ``jit=True`` is compiled (or loaded from the cache folder) in a
    background thread (`compiled.Background`), and the calls after it has ended return
    True, cold solves of the structure included. False for good without a C compiler or
    when the library could not be compiled or loaded safely (the virtual machine computes
    the same bits)."""
    if separable.key in _COMPILED:
        return True
    if separable.key not in _BACKGROUND and not (
            warm and compiler() is not None
            and _SPENT.get(separable.key, lambda: [0.0])[0] >= COMPILE_AFTER_SECONDS):
        return False
    loaded = _BACKGROUND.get(separable.key, lambda: _started(separable)).functions
    if loaded is None:
        return False
    _COMPILED.get(separable.key, lambda: loaded)
    return True


def spent(separable, seconds):
    """Count `seconds` of IPOPT on a warm re-solve of `separable` in the virtual machine
    towards its background compile (`compiled_when_ready`)."""
    _SPENT.get(separable.key, lambda: [0.0])[0] += seconds


def _started(separable):
    """The `Background` compile of `separable`'s library, its Functions made here (the
    serialization of the cache key is the thread's work)."""
    functions = list(separable.functions().values())
    return Background(lambda: Library(functions, "dmoc_nlp").load())
