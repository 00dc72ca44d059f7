"""The NLP of a DMOC problem evaluated as compiled C (consumer 2, ``optimize(...,
jit=True)``): its objective, constraints and the derivatives assembled from its terms
(`separable`), generated as C by CasADi, compiled once per NLP and machine and kept in the
private compiled-code cache that the simulator's steps use (`dmoc._util.compiled`, whose
libraries are loaded only when their bytes hash to their name and their Functions have the
signatures asked for). The C computes the same operations as CasADi's virtual machine, in
the same order, 4-6 times faster (docs/performance.md): a re-solve spends less time in
IPOPT's function evaluations, for a one-time compile of about a second.
"""

from .._util.cache import BoundedCache
from .._util.compiled import Library, compiler
from ..errors import InputError

_LOADED = BoundedCache(16, "compiled_nlps")      # keyed by SeparableNLP.key: {name: Function}


def nlp_functions(separable, jit):
    """``{name: Function}`` for the ``cache`` option of ``casadi.nlpsol``: with `jit`,
    `separable`'s five Functions (``separable.functions()``) loaded from their compiled
    library (compiled first unless it is in the cache folder); else its assembled
    derivatives, evaluated in CasADi's virtual machine.

    Raises
    ------
    InputError
        If `jit` and there is no C compiler.
    CompiledCodeError
        If the library can be neither compiled nor loaded safely (`Library.load` says why).
    """
    if not jit:
        return separable.derivatives()
    if compiler() is None:
        raise InputError("`jit=True` needs a C compiler: none found (set CC to one, or "
                         "leave jit=False for CasADi's virtual machine).")
    return _LOADED.get(separable.key,
                       lambda: Library(separable.functions().values(), "dmoc_nlp").load())
