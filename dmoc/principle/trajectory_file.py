"""The file of a Trajectory (the principle stage's discrete solution): every field as an
array of an uncompressed .npz archive, written atomically (`write`, behind
`Trajectory.save`) and read back exactly, never unpickled, with a file that is not one
refused by a TrajectoryFileError saying why (`read`, behind `Trajectory.load` and
`OptimizationResult.load`).
"""

import zipfile
from dataclasses import fields

import numpy as np

from .._util import checks
from .._util.files import atomic_write, readable_file, writable_file
from ..errors import InputError, InputTypeError, TrajectoryFileError

_REQUIRED = {"t", "q", "p", "lam", "u", "h", "variant"}
RESULT_PREFIX = "result_"       # the fields `OptimizationResult.save` adds to a trajectory file
TRAJECTORY_FILE = "a valid dmoc trajectory file (one written by Trajectory.save)"


def write(traj, path, extra=None):
    """Write every field of `traj` to an uncompressed .npz file at exactly `path`, atomically
    (`Trajectory.save`), with the arrays of `extra` ({name: array_like}, names starting
    with RESULT_PREFIX: `OptimizationResult.save`) beside them."""
    path = writable_file("path", checks.file_path("path", path))
    arrays = {f.name: np.asarray(getattr(traj, f.name)) for f in fields(traj)}
    with atomic_write(path) as file:
        np.savez(file, **arrays, **(extra or {}))


def read(cls, path, kind):
    """The `cls` (Trajectory) in the .npz file at `path`; a file that is not one raises
    TrajectoryFileError saying it is not `kind` (what the caller expected) and why."""
    path = readable_file("path", checks.file_path("path", path))
    with open(path, "rb") as file:
        head = file.read(4)
    if head != b"PK\x03\x04":         # every .npz file is a zip archive
        _invalid(path, kind, "it is empty" if not head else
                 "it is an .npy file (one array), not an .npz archive" if head == b"\x93NUM"
                 else "it is not an .npz (zip) archive")
    known = {f.name for f in fields(cls)}
    try:
        with np.load(path, allow_pickle=False) as data:
            names = set(data.files)
            values = {name: data[name] for name in names & known}
    except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile) as err:
        _invalid(path, kind, f"it is truncated or corrupted ({type(err).__name__}: {err})")
    missing = _REQUIRED - names
    unknown = {k for k in names - known if not k.startswith(RESULT_PREFIX)}
    if missing or unknown:
        _invalid(path, kind, f"it lacks the fields {sorted(missing)}" if missing else
                 f"it holds fields a Trajectory does not have: {sorted(unknown)}")
    for name in ("h", "variant"):
        if values[name].shape != ():
            _invalid(path, kind, f"`{name}` must be a single value; got shape {values[name].shape}")
    values["h"] = values["h"].item()
    values["variant"] = str(values["variant"])
    try:
        return cls(**values)
    except (InputError, InputTypeError) as err:
        _invalid(path, kind, f"its fields do not form a trajectory: {err}")


def _invalid(path, kind, reason):
    raise TrajectoryFileError(f"{str(path)!r} is not {kind}: {reason}.")
