"""CasADi's arithmetic on SX expressions through its typed entry point ``SX.binary``: the
expression nodes the operators make, without the overload resolution of CasADi's generic
Python functions, which tries every signature in turn (double, DM, SX, MX), calling back
into Python for shapes and type names: about 20 us a call (``x + y`` on two SX of 4
entries: 25 us, ``SX.binary``: 4 us), a large part of building a problem's step
expressions (benchmarks/peers.py first). (``SX.call`` is no such entry point for Function
calls: on a list of SX it takes the overload of scalar elements and makes call nodes.) Each function here makes the same nodes as the operator it
stands for (the serialized Functions, hence a problem's `structure`, are unchanged), and
falls back to the operator when an argument is not SX.
"""

import casadi as ca

_SX = ca.SX


def plus(a, b):
    """a + b."""
    if type(a) is _SX and type(b) is _SX:
        return _SX.binary(ca.OP_ADD, a, b)
    return a + b


def minus(a, b):
    """a - b."""
    if type(a) is _SX and type(b) is _SX:
        return _SX.binary(ca.OP_SUB, a, b)
    return a - b


def times(a, b):
    """a * b entrywise; a float factor enters as the SX constant the operator makes of it."""
    if type(b) is _SX and type(a) in (_SX, float):
        return _SX.binary(ca.OP_MUL, a if type(a) is _SX else _SX(a), b)
    if type(a) is _SX and type(b) is float:
        return _SX.binary(ca.OP_MUL, a, _SX(b))
    return a * b


def divide(a, b):
    """a / b entrywise."""
    if type(a) is _SX and type(b) is _SX:
        return _SX.binary(ca.OP_DIV, a, b)
    return a / b


def total(terms):
    """The sum of `terms` (a non-empty iterable) from the first, left to right: the nodes
    of ``0 + t_0 + t_1 + ...`` (CasADi drops the 0)."""
    terms = iter(terms)
    result = next(terms)
    for t in terms:
        result = plus(result, t)
    return result

