"""Argument handling of the command line: a parser whose errors are one line and exit 2,
and the readers of vectors with free entries, ``--param NAME=VALUE`` and control files
(the table ``optimize`` writes included, with its times and start).
"""

import argparse
import pathlib
import re
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from .._util.npz_archive import read_npy, regular_file
from . import output

FREE = ("free", "none", "nan")


class UsageError(Exception):
    """A bad command-line argument: `argument` names it, the message says what is wrong."""

    def __init__(self, argument, message):
        super().__init__(message if argument is None else f"argument {argument}: {message}")
        self.argument = argument


class Parser(argparse.ArgumentParser):
    """An ArgumentParser that raises UsageError instead of printing usage and exiting."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)
        # a value such as -0.8,none or -1,0,0 is a vector, not an option (argparse's own
        # pattern takes single numbers only)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message):
        argument, sep, rest = message.removeprefix("argument ").partition(": ")
        if message.startswith("argument ") and sep:
            raise UsageError(argument, rest)
        raise UsageError(None, f"{message} (see {self.prog} --help)")


def vector(option, text, names, *, free=False, of="this system"):
    """The comma-separated floats of `text` for the entries `names` (of `of`, for the
    error), shape (n,); entries "free" become NaN when `free` is allowed."""
    items = [s.strip() for s in text.replace(" ", ",").split(",") if s.strip()]
    if len(items) != len(names):
        raise UsageError(option, f"must have {len(names)} entries ({', '.join(names)}) for "
                         f"{of}; got {len(items)}")
    values = []
    for name, item in zip(names, items):
        if item.lower() in FREE:
            if not free:
                raise UsageError(option, f"entry {name} must be a number here; {item!r} is "
                                 f"allowed in --start, --goal, --velocity and the bounds of "
                                 f"optimize")
            values.append(np.nan)
            continue
        try:
            values.append(float(item))
        except ValueError:
            raise UsageError(option, f"entry {name} must be a number or 'free'; got {item!r}") from None
        if not np.isfinite(values[-1]):
            raise UsageError(option, f"entry {name} must be finite; got {item!r}")
    return np.array(values)


def params(items):
    """{name: number} from the ``--param NAME=VALUE`` options: an int where VALUE is an
    integer literal (``--param steps=40``), else a float."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        try:
            out[name.strip()] = int(value) if value.strip().lstrip("+-").isdigit() else float(value)
        except ValueError:
            raise UsageError("--param", f"must be NAME=VALUE with a number VALUE; got {item!r}") from None
        if not sep or not name.strip():
            raise UsageError("--param", f"must be NAME=VALUE; got {item!r}")
    return out


class RecordedControls(NamedTuple):
    """The controls of ``--controls FILE``, u of shape (N, columns); from a table that
    ``optimize`` wrote (`output.csv_columns`) also its knot times t, shape (N+1,), and its
    start q0, p0, shape (n,); None otherwise."""

    u: np.ndarray
    t: np.ndarray = None
    q0: np.ndarray = None
    p0: np.ndarray = None


def load_controls(file, names, n_u):
    """The RecordedControls of a .npy file or a text/CSV file (an optional header line is
    skipped) of controls, shape (N, n_u), or of the table ``optimize`` wrote for the
    coordinates `names` (its header starts with ``t``). Real numbers only: booleans,
    complex numbers and strings are refused (a float conversion would silently turn them
    into other controls)."""
    path = pathlib.Path(file)
    if not path.exists():
        raise UsageError("--controls", f"file {file!r} does not exist")
    if not path.is_file():
        raise UsageError("--controls", f"{file!r} is not a file")
    if path.suffix == ".npz":
        raise UsageError("--controls", f"{file!r} is a .npz archive; expected a .npy array or "
                         f"a .csv/.txt table, one row per step (hint: for the controls of a "
                         f"saved trajectory, np.save('u.npy', dmoc.Trajectory.load({file!r}).u))")
    try:
        if path.suffix == ".npy":
            with regular_file(path) as opened:
                return RecordedControls(_real_rows(read_npy(opened), n_u))
        header, rows = _load_text(path)
        if header[:1] != ["t"]:
            return RecordedControls(_real_rows(rows, n_u))
        run = output.run_table(header, rows, names)
    except UnicodeDecodeError:
        raise UsageError("--controls", f"{file!r} is not a text file (not UTF-8) and not a .npy "
                         f"file; expected a .npy array or a .csv/.txt table") from None
    except (ValueError, EOFError, OSError) as err:        # BadArchive is a ValueError
        raise UsageError("--controls", f"cannot read {file}: {err}") from None
    width = run["u"].shape[1]
    if width % n_u:
        raise UsageError("--controls", f"{file} has {width} control columns; this system "
                         f"has {n_u} controls (a table of another system?)")
    return RecordedControls(_real_rows(run["u"], width), run["t"], run["q"][0], run["p"][0])


# what a float conversion would do to arrays of these kinds, for the error
_NOT_REAL = {"b": ("booleans", "True/False would become 1.0/0.0; write the numbers you mean"),
             "c": ("complex numbers", "their imaginary part would be dropped; save np.real(u) "
                   "if it is zero"),
             "U": ("strings", "save numbers (np.save('u.npy', u.astype(float)) if they are "
                   "numbers written as text)"),
             "S": ("byte strings", "save numbers"), "V": ("records", "save a plain 2-D array"),
             "M": ("dates", "save numbers"), "m": ("time spans", "save numbers")}


def _real_rows(u, n_u):
    """`u` checked to be real numbers of shape (N, n_u) (a 1-D array when n_u == 1)."""
    u = np.asarray(u)
    if u.dtype.kind not in "iuf":
        what, hint = _NOT_REAL.get(u.dtype.kind, (f"dtype {u.dtype}", "save real numbers"))
        raise UsageError("--controls", f"must hold real numbers; got an array of {what} "
                         f"(dtype {u.dtype}); {hint}")
    u = u.astype(float)
    if u.ndim == 1 and n_u == 1:
        u = u[:, None]
    if u.ndim != 2 or u.shape[1] != n_u or u.shape[0] < 1:
        raise UsageError("--controls", f"must hold an array of shape (N, {n_u}) for this "
                         f"system, one row per step; got {u.shape}")
    if not np.isfinite(u).all():
        raise UsageError("--controls", "must hold finite numbers only")
    return u


def _load_text(path):
    """(the header's column names, [] without a header; the rows of numbers) of a text
    file whose first line is a header if it is not numbers."""
    lines = [line for line in path.read_text().splitlines() if line.strip()]
    if not lines:
        raise InputError("it is empty")
    delimiter = "," if "," in "".join(lines[:2]) else None
    try:
        return [], np.loadtxt(lines, delimiter=delimiter, ndmin=1)
    except ValueError:
        if len(lines) < 2:
            raise InputError("it holds no rows of numbers") from None
        header = [name.strip() for name in lines[0].split(delimiter)]
        return header, np.loadtxt(lines[1:], delimiter=delimiter, ndmin=1)


def output_folder(option, folder):
    """Create the output folder now, so that an unwritable path fails before any work."""
    if not folder.strip():
        raise UsageError(option, f"must name a folder; got {folder!r} (hint: {option} . "
                         f"writes into the current folder)")
    path = pathlib.Path(folder)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".dmoc-write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        raise UsageError(option, f"cannot write to folder {folder!r}: {err.strerror or err}") from None
    return path


def positive_int(text):
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer; got {text!r}")
    return value


def positive_float(text):
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite positive number; got {text!r}")
    return value
