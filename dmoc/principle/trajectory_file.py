"""The file of a Trajectory or a RotationTrajectory (the principle stage's discrete
solutions): every field as an array of an uncompressed .npz archive, written atomically
(`write`, behind `Trajectory.save` and `RotationTrajectory.save`) and read back exactly,
never unpickled, with a file that is not one refused by a TrajectoryFileError saying why
(`read`, behind their `load` and `OptimizationResult.load`): a file from elsewhere is read
with bounds (`npz_archive`) and every field checked against its type and shape.
"""

from dataclasses import MISSING, fields

import numpy as np

from .._util import checks
from .._util.files import atomic_write, readable_file, writable_file
from .._util.npz_archive import BadArchive, read_arrays, regular_file
from ..errors import InputError, InputTypeError, TrajectoryFileError

RESULT_PREFIX = "result_"       # the fields `OptimizationResult.save` adds to a trajectory file
TRAJECTORY_FILE = "a valid dmoc trajectory file (one written by Trajectory.save)"
ROTATION_TRAJECTORY_FILE = ("a valid dmoc trajectory file on SO(3) (one written by "
                            "RotationTrajectory.save)")
# a field only the other kind of trajectory has, and the reader of that kind
_OTHER_KIND = {"R": "a trajectory on SO(3) (read it with RotationTrajectory.load)",
               "q": "a trajectory of a vector space (read it with Trajectory.load)"}


def write(traj, path, extra=None):
    """Write every field of `traj` to an uncompressed .npz file at exactly `path`, atomically
    (`Trajectory.save`), with the arrays of `extra` ({name: array_like}, names starting
    with RESULT_PREFIX: `OptimizationResult.save`) beside them."""
    path = writable_file("path", checks.file_path("path", path))
    arrays = {f.name: np.asarray(getattr(traj, f.name)) for f in fields(traj)}
    with atomic_write(path) as file:
        np.savez(file, **arrays, **(extra or {}))


def read(cls, path, kind):
    """(the `cls` (Trajectory or RotationTrajectory; of a tuple of them the one of which
    the file holds the most fields without a default, the first of equals) in the .npz file at `path`, {name: array}
    of its fields named RESULT_PREFIX + name); a file that is not one raises
    TrajectoryFileError saying it is not `kind` (what the caller expected) and why: not a
    regular file, not an .npz archive, members named twice, sizes beyond bounds
    (`npz_archive`), fields missing (those of `cls` without a default), unknown or of the
    wrong type or shape, or the file of the other kind of trajectory."""
    path = readable_file("path", checks.file_path("path", path))
    try:
        with regular_file(path) as file:
            head = file.read(4)
            if head != b"PK\x03\x04":         # every .npz file is a zip archive
                _invalid(path, kind, "it is empty" if not head else
                         "it is an .npy file (one array), not an .npz archive" if head == b"\x93NUM"
                         else "it is not an .npz (zip) archive")
            file.seek(0)
            arrays = read_arrays(file)
    except BadArchive as err:
        _invalid(path, kind, str(err))
    if isinstance(cls, tuple):          # the kind whose fields the file holds most of
        cls = max(cls, key=lambda kind: len(_required(kind) & set(arrays)))
    known = {f.name for f in fields(cls)}
    missing = _required(cls) - set(arrays)
    unknown = {k for k in set(arrays) - known if not k.startswith(RESULT_PREFIX)}
    other = [_OTHER_KIND[name] for name in _OTHER_KIND if name in unknown]
    if missing or unknown:
        _invalid(path, kind, f"it is the file of {other[0]}" if other else
                 f"it lacks the fields {sorted(missing)}" if missing else
                 f"it holds fields a {cls.__name__} does not have: {sorted(unknown)}")
    values = {name: arrays[name] for name in set(arrays) & known}
    values["h"] = scalar(path, kind, "h", values["h"], "fiu").item()
    if "variant" in values:
        values["variant"] = str(scalar(path, kind, "variant", values["variant"], "U"))
    try:
        traj = cls(**values)
    except (InputError, InputTypeError) as err:
        _invalid(path, kind, f"its fields do not form a trajectory: {err}")
    return traj, {k[len(RESULT_PREFIX):]: v for k, v in arrays.items() if k.startswith(RESULT_PREFIX)}


def _required(cls):
    """The names of the fields of the dataclass `cls` without a default."""
    return {f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING}


def scalar(path, kind, name, value, kinds):
    """The 0-d array `value` of field `name`, when its dtype's kind is one of `kinds`
    ("U" text, "b" bool, "f", "i", "u" real numbers); else TrajectoryFileError naming it."""
    if value.shape != ():
        _invalid(path, kind, f"`{name}` must be a single value; got shape {value.shape}")
    if value.dtype.kind not in kinds:
        _invalid(path, kind, f"`{name}` must be {_KINDS[kinds]}; got dtype {value.dtype}")
    return value


_KINDS = {"fiu": "a real number", "U": "text", "b": "a bool (True or False)", "f": "a float"}


def _invalid(path, kind, reason):
    raise TrajectoryFileError(f"{str(path)!r} is not {kind}: {reason}.")
