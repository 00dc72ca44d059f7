"""The one routine that turns a user callable into a named CasADi Function: it calls the
callable on symbols of the declared sizes and reports every problem (not callable, raised,
wrong shape, stray symbols) in the library's message format, for the system data L, A(q),
f of (27) and for the optimizer's costs and path constraints alike.
"""

import casadi as ca

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
        raw = ca.SX(fun(*symbols))
    except Exception as err:  # any failure inside user code is reported, not swallowed
        problems.append(f"`{name}` failed on symbols of the declared sizes [{sizes}]: "
                        f"{type(err).__name__}: {err}")
        return None
    out = ca.vec(raw) if shape is None else _oriented(raw, shape)
    if out is None:
        expected = "(" + ", ".join("k" if s is None else str(s) for s in shape) + ")"
        problems.append(f"`{name}` must return shape {expected}; got {raw.shape}.")
        return None
    try:
        return ca.Function(label, list(symbols), [out], list(arg_names), [label])
    except RuntimeError:
        free = [str(x) for x in ca.symvar(out) if not any(ca.depends_on(x, s) for s in symbols)]
        problems.append(f"`{name}` uses symbols that are not its arguments: {free}; build it "
                        f"from the arguments it is called with.")
        return None


def checked_function(name, fun, symbols, arg_names, shape, *, label=None):
    """`user_function` raising at once: TypeError if `fun` is not callable, else ValueError."""
    if not callable(fun):
        raise InputTypeError(f"`{name}` must be callable; got {type(fun).__name__}.")
    problems = []
    function = user_function(name, fun, symbols, arg_names, shape, problems, label=label)
    if problems:
        raise InputError(problems[0])
    return function


def _fits(actual, shape):
    return all(s is None or a == s for a, s in zip(actual, shape))


def _oriented(out, shape):
    """`out` if it fits `shape`, its transpose if a vector fits that way, else None."""
    if _fits(out.shape, shape):
        return out
    if min(out.shape) <= 1 and _fits(out.shape[::-1], shape):
        return out.T
    return None
