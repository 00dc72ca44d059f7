"""The one routine that turns a user callable into a named CasADi Function: it calls the
callable on symbols of the declared sizes and reports every problem (not callable, raised,
wrong shape, stray symbols, numbers made of symbols by math or numpy functions) in the
library's message format, for the system data L, A(q), f of (27) and for the optimizer's
costs and path constraints alike.
"""

import math

import casadi as ca

from . import typed_ops
from ..errors import InputError, InputTypeError


def user_function(name, fun, symbols, arg_names, shape, problems, *, label=None):
    """The Function ``label(*symbols)`` of ``fun(*symbols)``, or None with `problems` appended.

    Parameters
    ----------
    name : str
        The argument the user passed `fun` as, named in every message.
    fun : callable
    symbols : sequence of casadi.SX
        Column symbols of the declared sizes, the arguments of `fun`.
    arg_names : sequence of str
        Names of the Function's inputs.
    shape : (int or None, int or None) or None
        Expected output shape; None entries accept any size. A vector returned along the
        other axis is transposed. ``shape=None`` accepts any shape and flattens it to a
        column (column-major).
    problems : list of str
        Messages are appended here; the caller raises them together.
    label : str, optional
        Name of the Function and of its output (default `name`).
    """
    label = label or name
    if not callable(fun):
        problems.append(f"`{name}` must be callable; got {type(fun).__name__}.")
        return None
    sizes = ", ".join(f"{a} ({s.numel()},)" for a, s in zip(arg_names, symbols))
    try:
        value = fun(*symbols)
    except Exception as err:  # any failure inside user code is reported, not swallowed
        problems.append(f"`{name}` failed on symbols of the declared sizes [{sizes}]: "
                        f"{type(err).__name__}: {err}{_numeric_hint(err)}")
        return None
    try:
        raw = typed_ops.sx(value)
    except Exception:  # a list of expressions, or an object CasADi cannot convert
        problems.append(f"`{name}` must return a CasADi expression; got a "
                        f"{type(value).__name__} it cannot convert{_container_hint(value)}.")
        return None
    out = ca.vec(raw) if shape is None else _oriented(raw, shape)
    if out is None:
        expected = "(" + ", ".join("k" if s is None else str(s) for s in shape) + ")"
        problems.append(f"`{name}` must return shape {expected}; got {raw.shape}.")
        return None
    try:
        function = ca.Function(label, list(symbols), [out], list(arg_names), [label])
    except RuntimeError:
        free = [str(x) for x in ca.symvar(out) if not any(ca.depends_on(x, s) for s in symbols)]
        problems.append(f"`{name}` uses symbols that are not its arguments: {free}; build it "
                        f"from the arguments it is called with.")
        return None
    if _has_nan_constant(function):
        problems.append(f"`{name}` must be built from CasADi operations on its symbolic "
                        f"arguments; got an expression holding a NaN constant, which is what a "
                        f"Python math or numpy function that needs a number (math.sin(q[0]), "
                        f"float(q[0]), np.float64(q[0])) makes of a symbol. {SYMBOLIC_HINT}")
        return None
    return function


def checked_function(name, fun, symbols, arg_names, shape, *, label=None):
    """`user_function` raising at once: TypeError if `fun` is not callable, else ValueError."""
    if not callable(fun):
        raise InputTypeError(f"`{name}` must be callable; got {type(fun).__name__}.")
    problems = []
    function = user_function(name, fun, symbols, arg_names, shape, problems, label=label)
    if problems:
        raise InputError(problems[0])
    return function


SYMBOLIC_HINT = ("The arguments are CasADi SX symbols: use CasADi's functions on them "
                 "(ca.sin, ca.sqrt, ca.fabs, ca.atan2, ca.if_else for a branch), not math's "
                 "or numpy functions that convert them to numbers.")

# What CasADi raises when user code asks a symbol for a number: float() of a non-scalar SX
# (math.sin(q)), int() of a symbol, the truth value of a comparison (`if q[0] > 0:`),
# numpy's conversion of a symbolic matrix to a numeric array.
_NUMERIC_CONVERSIONS = ('"is_scalar()" failed', "to_int not defined", "truth value",
                        "Implicit conversion of symbolic")


def _container_hint(value):
    """How to build the expression when `value` is a Python list or tuple."""
    if not isinstance(value, (list, tuple)):
        return ""
    nested = any(isinstance(item, (list, tuple)) for item in value)
    return (": build each row with ca.horzcat(...) and stack the rows with ca.vertcat(...)"
            if nested else ": stack the entries with ca.vertcat(...) (a row: ca.horzcat(...))")


def _numeric_hint(err):
    """SYMBOLIC_HINT after a space when `err` is CasADi refusing to turn a symbol into a
    number, else ""."""
    text = str(err)
    return " " + SYMBOLIC_HINT if any(s in text for s in _NUMERIC_CONVERSIONS) else ""


def _has_nan_constant(function):
    """Whether the SX `function` holds a NaN constant. CasADi turns a scalar symbol into
    NaN where Python asks it for a float (math.sin(q[0])): the expression still depends
    on the other symbols and evaluates to NaN everywhere. CasADi operations on symbols
    make no NaN constant (only a NaN written in, or folded from one, e.g. sqrt(-1))."""
    return any(function.instruction_id(k) == ca.OP_CONST
               and math.isnan(function.instruction_constant(k))
               for k in range(function.n_instructions()))


def _fits(actual, shape):
    return all(s is None or a == s for a, s in zip(actual, shape))


def _oriented(out, shape):
    """`out` if it fits `shape`, its transpose if a vector fits that way, else None."""
    if _fits(out.shape, shape):
        return out
    if min(out.shape) <= 1 and _fits(out.shape[::-1], shape):
        return out.T
    return None
