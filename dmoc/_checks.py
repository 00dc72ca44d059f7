"""Argument validation shared by the whole library, with one message format.

Every message names the argument, what was expected and what was given, e.g.
"`q0` must have shape (3,) for this system; got (2,)."
"""

import numbers

import numpy as np


def choice(name, value, options):
    """Return `value` if it is one of `options`, else raise ValueError listing them."""
    if not isinstance(value, str) or value not in options:
        listed = ", ".join(repr(o) for o in options)
        raise ValueError(f"`{name}` must be one of {listed}; got {value!r}.")
    return value


def positive_int(name, value):
    """Return `value` as int if it is an integer >= 1."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"`{name}` must be a positive integer; got {value!r}.")
    return int(value)


def nonnegative_int(name, value):
    """Return `value` as int if it is an integer >= 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(f"`{name}` must be a non-negative integer; got {value!r}.")
    return int(value)


def _real(name, value):
    """`value` as a float: a real number or a 0-d real array, never a bool."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and np.isrealobj(value):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"`{name}` must be a real number; got {type(value).__name__}.")
    return float(value)


def boolean(name, value):
    """Return `value` if it is a bool."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False; got {value!r}.")
    return bool(value)


def positive_float(name, value):
    """Return `value` as float if it is a finite real number > 0."""
    value = _real(name, value)
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"`{name}` must be finite and positive; got {value!r}.")
    return value


def finite_float(name, value):
    """Return `value` as float if it is a finite real number."""
    value = _real(name, value)
    if not np.isfinite(value):
        raise ValueError(f"`{name}` must be finite; got {value!r}.")
    return value


def array(name, value, shape, *, allow_nan=False):
    """Return `value` as a float array of exactly `shape`, finite unless `allow_nan`.

    `allow_nan` lets NaN stand for "free" entries (never infinities).
    """
    raw = np.asarray(value)
    if raw.dtype.kind not in "iuf":     # no strings, booleans or objects passed off as numbers
        raise TypeError(f"`{name}` must be an array of real numbers of shape {tuple(shape)}; "
                        f"got {type(value).__name__} of {raw.dtype}.")
    out = np.array(raw, dtype=float)
    if out.shape != tuple(shape):
        raise ValueError(f"`{name}` must have shape {tuple(shape)} for this system; got {out.shape}.")
    bad = np.isinf(out) if allow_nan else ~np.isfinite(out)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"`{name}` must be finite; entry {where} is {out[where]!r}.")
    return out


def no_unknown_keys(name, given, known):
    """Raise ValueError if the mapping `given` has keys outside `known`."""
    unknown = sorted(set(given) - set(known))
    if unknown:
        raise ValueError(
            f"`{name}` has unknown keys {unknown}; known keys are {sorted(known)}."
        )


def array_with_none(name, value, size, fill):
    """Return `value` (shape (size,), or a scalar broadcast to it) as floats, None -> `fill`."""
    raw = np.array(value, dtype=object)
    if raw.ndim == 0:
        raw = np.full(size, raw.item(), dtype=object)
    if raw.shape != (size,):
        raise ValueError(f"`{name}` must have shape ({size},) for this system; got {raw.shape}.")
    try:
        return np.array([fill if x is None else float(x) for x in raw], dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must hold real numbers or None; got {value!r}.") from None
