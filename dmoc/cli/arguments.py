"""Argument handling of the command line: a parser whose errors are one line and exit 2,
and the readers of vectors with free entries, ``--param NAME=VALUE`` and control files.
"""

import argparse
import pathlib

import numpy as np

from ..errors import InputError

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

    def error(self, message):
        argument, sep, rest = message.removeprefix("argument ").partition(": ")
        if message.startswith("argument ") and sep:
            raise UsageError(argument, rest)
        raise UsageError(None, f"{message} (see {self.prog} --help)")


def vector(option, text, names, *, free=False):
    """The comma-separated floats of `text` for the coordinates `names`, shape (n,);
    entries "free" become NaN when `free` is allowed."""
    items = [s.strip() for s in text.replace(" ", ",").split(",") if s.strip()]
    if len(items) != len(names):
        raise UsageError(option, f"must have {len(names)} entries ({', '.join(names)}) for "
                         f"this system; got {len(items)}")
    values = []
    for name, item in zip(names, items):
        if item.lower() in FREE:
            if not free:
                raise UsageError(option, f"entry {name} must be a number; free entries are "
                                 f"allowed only in --start/--goal of optimize")
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
    """{name: float} from the ``--param NAME=VALUE`` options."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise UsageError("--param", f"must be NAME=VALUE with a number VALUE; got {item!r}") from None
        if not sep or not name.strip():
            raise UsageError("--param", f"must be NAME=VALUE; got {item!r}")
    return out


def load_controls(file, n_u):
    """Controls u_k from a .npy file or a text/CSV file (an optional header line is
    skipped), shape (N, n_u)."""
    path = pathlib.Path(file)
    if not path.exists():
        raise UsageError("--controls", f"file {file!r} does not exist")
    if not path.is_file():
        raise UsageError("--controls", f"{file!r} is not a file")
    try:
        if path.suffix == ".npy":
            u = np.load(path, allow_pickle=False)
        else:
            u = _load_text(path)
    except (ValueError, EOFError, OSError) as err:
        raise UsageError("--controls", f"cannot read {file}: {err}") from None
    u = np.asarray(u, dtype=float)
    if u.ndim == 1 and n_u == 1:
        u = u[:, None]
    if u.ndim != 2 or u.shape[1] != n_u or u.shape[0] < 1:
        raise UsageError("--controls", f"must hold an array of shape (N, {n_u}) for this "
                         f"system, one row per step; got {u.shape}")
    if not np.isfinite(u).all():
        raise UsageError("--controls", "must hold finite numbers only")
    return u


def _load_text(path):
    """Rows of numbers of a text file, its first line skipped if it is not numbers."""
    lines = [line for line in path.read_text().splitlines() if line.strip()]
    if not lines:
        raise InputError("it is empty")
    delimiter = "," if "," in "".join(lines[:2]) else None
    try:
        return np.loadtxt(lines, delimiter=delimiter, ndmin=1)
    except ValueError:
        if len(lines) < 2:
            raise InputError("it holds no rows of numbers") from None
        return np.loadtxt(lines[1:], delimiter=delimiter, ndmin=1)


def output_folder(option, folder):
    """Create the output folder now, so that an unwritable path fails before any work."""
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
