"""Argument validation shared by the whole library, with one message format.

Every message names the argument, what was expected and what was given, e.g.
"`q0` must have shape (3,) for this system; got (2,)." A wrong value raises `InputError`
(a ValueError), a wrong kind of object `InputTypeError` (a TypeError); both are
`DmocError` (docs/errors.md).
"""

import numbers
import os
import pathlib

import numpy as np

from ..errors import InputError, InputTypeError


def choice(name, value, options):
    """Return `value` if it is one of `options`, else raise InputError listing them."""
    if not isinstance(value, str) or value not in options:
        listed = ", ".join(repr(o) for o in options)
        raise InputError(f"`{name}` must be one of {listed}; got {value!r}.")
    return value


def instance(name, value, kinds, described):
    """Return `value` if it is an instance of `kinds`, else raise InputTypeError saying
    `described` (e.g. "a Discretization")."""
    if not isinstance(value, kinds):
        raise InputTypeError(f"`{name}` must be {described}; got {type(value).__name__}.")
    return value


def positive_int(name, value):
    """Return `value` as int if it is an integer >= 1."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise InputError(f"`{name}` must be a positive integer; got {value!r}.")
    return int(value)


def nonnegative_int(name, value):
    """Return `value` as int if it is an integer >= 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise InputError(f"`{name}` must be a non-negative integer; got {value!r}.")
    return int(value)


def _real(name, value):
    """`value` as a float: a real number or a 0-d real array, never a bool."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and np.isrealobj(value):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputTypeError(f"`{name}` must be a real number; got {type(value).__name__}.")
    return float(value)


def boolean(name, value):
    """Return `value` if it is a bool."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputTypeError(f"`{name}` must be True or False; got {value!r}.")
    return bool(value)


def positive_float(name, value):
    """Return `value` as float if it is a finite real number > 0."""
    value = _real(name, value)
    if not np.isfinite(value) or value <= 0.0:
        raise InputError(f"`{name}` must be finite and positive; got {value!r}.")
    return value


def step_size(name, value):
    """Return the step `value` as float if it is finite and at least the smallest normal
    float (below it 1/h, and every momentum (q_1 - q_0)/h, overflows to inf)."""
    value = positive_float(name, value)
    tiny = float(np.finfo(float).tiny)
    if value < tiny:
        raise InputError(f"`{name}` must be at least {tiny!r} (the smallest normal float: "
                         f"1/{name} overflows below it); got {value!r}.")
    return value


def nonnegative_float(name, value):
    """Return `value` as float if it is a finite real number >= 0."""
    value = _real(name, value)
    if not np.isfinite(value) or value < 0.0:
        raise InputError(f"`{name}` must be finite and nonnegative; got {value!r}.")
    return value


def finite_float(name, value):
    """Return `value` as float if it is a finite real number."""
    value = _real(name, value)
    if not np.isfinite(value):
        raise InputError(f"`{name}` must be finite; got {value!r}.")
    return value


def real_array(name, value, expected="an array of real numbers"):
    """`value` as a float array of any shape: integers and floats only, never strings,
    booleans, complex numbers, objects, ragged nesting or symbolic CasADi expressions."""
    try:
        raw = np.asarray(value)
    except ValueError:                  # numpy refuses ragged nesting
        raise InputError(f"`{name}` must be {expected}; got a ragged nested sequence "
                         f"(rows of different lengths).") from None
    except TypeError:                   # e.g. casadi.SX/MX refuse conversion to numbers
        raise InputTypeError(f"`{name}` must be {expected}; got a symbolic "
                             f"{type(value).__name__} (evaluate it to numbers first).") from None
    if raw.dtype.kind not in "iuf":     # no strings, booleans or objects passed off as numbers
        raise InputTypeError(f"`{name}` must be {expected}; got {type(value).__name__} "
                             f"of {raw.dtype}.")
    return np.array(raw, dtype=float)


def array(name, value, shape, *, allow_nan=False):
    """Return `value` as a float array of exactly `shape`, finite unless `allow_nan`.

    `allow_nan` lets NaN stand for "free" entries (never infinities).
    """
    out = real_array(name, value, f"an array of real numbers of shape {tuple(shape)}")
    if out.shape != tuple(shape):
        raise InputError(f"`{name}` must have shape {tuple(shape)} for this system; got {out.shape}.")
    bad = np.isinf(out) if allow_nan else ~np.isfinite(out)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InputError(f"`{name}` must be finite; entry {where} is {float(out[where])!r}.")
    return out


def vector(name, value, size=None, *, allow_nan=False):
    """Return `value` as a 1-D float array (of `size` entries if given), finite unless
    `allow_nan` (then NaN marks a missing value, e.g. a failed solve's cost)."""
    out = real_array(name, value, "a 1-D array of real numbers")
    if out.ndim != 1 or (size is not None and out.size != size):
        raise InputError(f"`{name}` must have shape ({'K' if size is None else size},); "
                         f"got {out.shape}.")
    return array(name, out, out.shape, allow_nan=allow_nan)


def column(name, value, n):
    """Return `value` as int if it is a column index of q: an integer in [0, n)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 0 <= value < n:
        raise InputError(f"`{name}` must be a column of q, an integer in [0, {n}); got {value!r}.")
    return int(value)


def strings(name, value, count):
    """Return `value` as a tuple of `count` strings (names of coordinates, of controls)."""
    if isinstance(value, str) or not hasattr(value, "__iter__"):
        raise InputTypeError(f"`{name}` must be a sequence of {count} strings; "
                             f"got {type(value).__name__}.")
    value = tuple(value)
    if len(value) != count or not all(isinstance(s, str) for s in value):
        raise InputError(f"`{name}` must be {count} strings; got {value!r}.")
    return value


def file_path(name, value):
    """Return `value` as a pathlib.Path if it is a str or an os.PathLike."""
    return pathlib.Path(instance(name, value, (str, os.PathLike), "a path (str or os.PathLike)"))


def no_unknown_keys(name, given, known):
    """Raise InputError if the mapping `given` has keys outside `known`."""
    unknown = sorted(set(given) - set(known), key=repr)
    if unknown:
        raise InputError(
            f"`{name}` has unknown keys {unknown}; known keys are {sorted(known)}."
        )


def array_with_none(name, value, size, fill):
    """Return `value` (shape (size,), or a scalar broadcast to it) as floats, None -> `fill`.

    Only None means `fill`: NaN, booleans and strings are refused, not read as numbers.
    """
    raw = np.array(value, dtype=object)
    if raw.ndim == 0:
        raw = np.full(size, raw.item(), dtype=object)
    if raw.shape != (size,):
        raise InputError(f"`{name}` must have shape ({size},) for this system; got {raw.shape}.")
    out = np.empty(size)
    for i, x in enumerate(raw):
        if x is None:
            out[i] = fill
            continue
        if not isinstance(x, float) and (isinstance(x, (bool, np.bool_))    # floats pass at once
                                         or not isinstance(x, numbers.Real)):
            raise InputTypeError(f"`{name}` must hold real numbers or None; entry {i} is {x!r}.")
        try:
            out[i] = x
        except OverflowError:
            raise InputError(f"`{name}` entry {i} is too large for a float.") from None
        if out[i] != out[i]:        # NaN
            raise InputError(f"`{name}` entry {i} is NaN; only None leaves an entry free "
                             f"(unbounded, for bounds).")
    return out


def bound_pair(name, value, size):
    """(lower, upper) arrays of shape (size,) with None entries unbounded."""
    if value is None:
        return np.full(size, -np.inf), np.full(size, np.inf)
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise InputError(f"`{name}` must be a pair (lower, upper) of arrays of shape ({size},).")
    lower = array_with_none(name, value[0], size, -np.inf)
    upper = array_with_none(name, value[1], size, np.inf)
    if np.isnan(lower).any() or np.isnan(upper).any() or (lower > upper).any():
        raise InputError(f"`{name}` must satisfy lower <= upper without NaN; got {lower}, {upper}.")
    if (lower == np.inf).any() or (upper == -np.inf).any():
        raise InputError(f"`{name}` must have lower bounds below +inf and upper bounds above "
                         f"-inf (None or -inf/+inf there means unbounded); got {lower}, {upper}.")
    return lower, upper


# IPOPT's integer options (IPOPT's options reference, "The valid range for this integer
# option", and the advanced ones of `print_advanced_options`): CasADi truncates a float
# given for one (max_iter 3.7 runs 3 iterations), so a non-integral float is refused.
IPOPT_INTEGER_OPTIONS = frozenset((
    "print_level", "file_print_level", "print_frequency_iter", "max_iter", "acceptable_iter",
    "max_resto_iter", "max_soc", "soc_method", "watchdog_shortened_iter_trigger",
    "watchdog_trial_iter_max", "accept_after_max_steps", "max_filter_resets",
    "filter_reset_trigger", "num_linear_variables", "quality_function_max_section_steps",
    "max_refinement_steps", "min_refinement_steps", "limited_memory_max_history",
    "limited_memory_max_skipping", "derivative_test_first_index",
    "ma27_print_level", "ma57_pivot_order", "ma57_block_size", "ma57_node_amalgamation",
    "ma57_small_pivot_flag", "ma77_print_level", "ma77_buffer_lpage", "ma77_buffer_npage",
    "ma77_file_size", "ma77_maxstore", "ma77_nemin", "ma86_print_level", "ma86_nemin",
    "ma97_print_level", "ma97_nemin", "mumps_print_level", "mumps_mem_percent",
    "mumps_permuting_scaling", "mumps_pivot_order", "mumps_scaling",
    "pardiso_max_iterative_refinement_steps", "pardiso_msglvl",
    "pardisomkl_max_iterative_refinement_steps", "pardisomkl_msglvl", "spral_print_level",
    "spral_nemin", "spral_cpu_block_size", "wsmp_num_threads", "wsmp_ordering_option",
    "wsmp_scaling"))

# The entries of `options` that are dmoc's switches of `optimize` (its SWITCHES, in the
# deprecated options spelling), not IPOPT's: the only entries that take a bool.
IPOPT_INT_MIN, IPOPT_INT_MAX = -2**31, 2**31 - 1      # IPOPT's Index: a C int
SWITCH_ENTRIES = ("reuse_solver", "expand", "linear_solver_report")


def ipopt_options(name, options):
    """Return `options` as a dict of IPOPT options: string keys, values that are a number
    or a string (None is refused: it would be dropped, not set), an integer (or an
    integral float, returned as int) for IPOPT's integer options. A bool is refused except
    for `SWITCH_ENTRIES`: IPOPT reads True as the number 1, and its yes/no options take
    the strings "yes" and "no". Numbers must be finite (IPOPT takes a NaN tolerance) and
    integers fit IPOPT's 32-bit integers (2**32 + 3 iterations would wrap to 3)."""
    if not isinstance(options, dict):
        raise InputTypeError(f"`{name}` must be a dict of IPOPT options; got {type(options).__name__}.")
    checked = {}
    for key, value in options.items():
        if not isinstance(key, str):
            raise InputTypeError(f"`{name}` must have string keys (IPOPT option names); "
                                 f"got the key {key!r}.")
        if not isinstance(value, (bool, np.bool_, numbers.Real, str)):
            raise InputTypeError(f"`{name}['{key}']` must be a number, a string or a bool; "
                                 f"got {value!r}.")
        checked[key] = value if key in SWITCH_ENTRIES else _ipopt_value(name, key, value)
    return checked


def _ipopt_value(name, key, value):
    """`value` checked for the IPOPT option `key` (a name after the last "." is looked up,
    e.g. "resto.max_iter")."""
    integer = key.rsplit(".", 1)[-1] in IPOPT_INTEGER_OPTIONS
    if isinstance(value, (bool, np.bool_)):
        hint = "" if integer else " IPOPT's yes/no options take the strings 'yes' and 'no'."
        raise InputTypeError(
            f"`{name}['{key}']` must be {'an integer' if integer else 'a number or a string'}, "
            f"not a bool; got {value!r} (IPOPT would read it as {int(value)}).{hint}")
    if isinstance(value, str):
        return value
    if not np.isfinite(value):
        raise InputError(f"`{name}['{key}']` must be finite; got {value!r} (IPOPT's 'no limit' "
                         f"is a large number, e.g. 1e20).")
    if integer:
        if not float(value).is_integer():
            raise InputError(f"`{name}['{key}']` must be an integer (an IPOPT integer "
                             f"option); got {value!r}, which IPOPT would truncate to {int(value)}.")
        if not IPOPT_INT_MIN <= int(value) <= IPOPT_INT_MAX:
            raise InputError(f"`{name}['{key}']` must be an integer from {IPOPT_INT_MIN} to "
                             f"{IPOPT_INT_MAX} (IPOPT's 32-bit integers, which would wrap "
                             f"it); got {value!r}.")
        return int(value)
    return value
