"""CasADi's arithmetic on symbolic expressions (SX, MX) through its typed entry points
(``SX.binary``, ``MX.binary``): the expression nodes the operators make, without the
overload resolution of CasADi's generic Python functions, which tries every signature in
turn (double, DM, SX, MX), calling back into Python for shapes and type names: about 20 us
a call on SX and 50 us on MX (``x + y`` on two SX of 4 entries: 25 us, ``SX.binary``: 4 us;
``x < y`` on two MX: 64 us, ``MX.binary``: 3 us), a large part of building a problem and
its solver (benchmarks/peers.py first). Each function makes the same nodes as the operator
it stands for (the serialized Functions, hence a problem's `structure`, are unchanged) and
falls back to the operator when its arguments are not both SX or both MX. (``SX.call`` is
no such entry point for Function calls: on a list of SX it takes the overload of scalar
elements and makes call nodes.)
"""

import casadi as ca

_SYMBOLIC = (ca.SX, ca.MX)


def _binary(op, a, b):
    """The node of ``op`` on a and b when both are SX or both MX (a float promoted to the
    other's type, as the operator promotes it), else None."""
    kind = type(a)
    if kind in _SYMBOLIC:
        if type(b) is kind:
            return kind.binary(op, a, b)
        if type(b) is float:
            return kind.binary(op, a, kind(b))
    elif type(a) is float and type(b) in _SYMBOLIC:
        return type(b).binary(op, type(b)(a), b)
    return None


def plus(a, b):
    """a + b."""
    out = _binary(ca.OP_ADD, a, b)
    return a + b if out is None else out


def minus(a, b):
    """a - b."""
    out = _binary(ca.OP_SUB, a, b)
    return a - b if out is None else out


def times(a, b):
    """a * b entrywise."""
    out = _binary(ca.OP_MUL, a, b)
    return a * b if out is None else out


def divide(a, b):
    """a / b entrywise."""
    out = _binary(ca.OP_DIV, a, b)
    return a / b if out is None else out


def less(a, b):
    """a < b entrywise (1 or 0)."""
    out = _binary(ca.OP_LT, a, b)
    return a < b if out is None else out


def equal(a, b):
    """a == b entrywise (1 or 0), a and b both SX or both MX (a float on the left takes
    the operator, which Python reflects: ``2.5 == x`` is ``x == 2.5``)."""
    out = _binary(ca.OP_EQ, a, b) if type(a) is not float else None
    return a == b if out is None else out


def total(terms):
    """The sum of `terms` (a non-empty iterable) from the first, left to right: the nodes
    of ``0 + t_0 + t_1 + ...`` (CasADi drops the 0)."""
    terms = iter(terms)
    result = next(terms)
    for t in terms:
        result = plus(result, t)
    return result


def column(x):
    """``ca.vec(x)``: an SX or MX column itself (vec returns its node), else vec."""
    return x if type(x) in _SYMBOLIC and x.size2() == 1 else ca.vec(x)


def sx(x):
    """``ca.SX(x)``: an SX itself (the constructor on an SX converts it anew, through SWIG's
    overload resolution), anything else converted."""
    return x if type(x) is ca.SX else ca.SX(x)


def fabs(x):
    """|x| entrywise."""
    return type(x).unary(ca.OP_FABS, x) if type(x) in _SYMBOLIC else ca.fabs(x)


def less_equal(a, b):
    """a <= b entrywise (1 or 0)."""
    out = _binary(ca.OP_LE, a, b)
    return a <= b if out is None else out


def logic_not(x):
    """not x entrywise (1 or 0)."""
    return type(x).unary(ca.OP_NOT, x) if type(x) in _SYMBOLIC else ca.logic_not(x)
