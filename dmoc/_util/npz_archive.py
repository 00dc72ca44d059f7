"""The arrays of an .npz archive or an .npy file that may have been crafted (a trajectory
or result file from elsewhere, the command line's ``--controls``), read with bounds: only a
regular file is opened (a FIFO or a device is refused without blocking), a member name may
appear once, every .npy header is read first and its declared shape and type checked
against the member's (or file's) size before anything is allocated (a declared shape of
10**12 is refused, not a MemoryError), compressed members may inflate to at most
MAX_INFLATED_BYTES in all (a small file declaring gigabytes is refused, not inflated),
stored ones are bounded by the file's own size, and nothing is unpickled (object arrays are
refused). A file that is not such an archive raises `BadArchive` (a ValueError) saying why.
"""

import contextlib
import math
import os
import stat
import zipfile

import numpy as np

MAX_INFLATED_BYTES = 2**30      # the bound of the compressed members' total inflated size
_OPEN = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)


class BadArchive(ValueError):
    """The file is not a readable .npz archive; the message says why."""


@contextlib.contextmanager
def regular_file(path):
    """The file at `path` opened for binary reading, when it is a regular file (a FIFO is
    opened without waiting for a writer, then refused)."""
    fd = os.open(path, _OPEN)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a device"
                    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket"
                    if stat.S_ISSOCK(mode) else "not a regular file")
            raise BadArchive(f"it is {kind}, not a regular file")
        file = os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise
    with file:
        yield file


def read_arrays(file):
    """{member name without ".npy": array} of the .npz archive open as `file` (binary,
    seekable), each checked as the module notes say before it is read."""
    size = os.fstat(file.fileno()).st_size
    try:
        with zipfile.ZipFile(file) as archive:
            members = archive.infolist()
            names = [info.filename for info in members]
            twice = sorted({name for name in names if names.count(name) > 1})
            if twice:
                raise BadArchive(f"it holds the members {twice} more than once")
            inflated = sum(i.file_size for i in members if i.compress_type != zipfile.ZIP_STORED)
            if inflated > MAX_INFLATED_BYTES:
                raise BadArchive(f"its compressed members declare {inflated} bytes in all, "
                                 f"more than the {MAX_INFLATED_BYTES} a file may inflate to")
            return {_field(info): _array(archive, info, size) for info in members}
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError, NotImplementedError,
            RuntimeError, UnicodeDecodeError) as err:
        raise BadArchive(f"it is truncated or corrupted ({type(err).__name__}: {err})") from None


def _field(info):
    if not info.filename.endswith(".npy"):
        raise BadArchive(f"its member {info.filename!r} is not an .npy array")
    return info.filename[:-len(".npy")]


def _array(archive, info, size):
    """The array of member `info`, its header checked first (see the module notes)."""
    name = info.filename
    if info.compress_type == zipfile.ZIP_STORED and (info.file_size != info.compress_size
                                                     or info.file_size > size):
        raise BadArchive(f"its member {name!r} declares {info.file_size} bytes, but the file "
                         f"holds {min(info.compress_size, size)}")
    with archive.open(info) as member:
        _check_header(member, f"its member {name!r}", info.file_size)
    with archive.open(info) as member:
        return np.lib.format.read_array(member, allow_pickle=False)


def read_npy(file):
    """The array of the .npy file open as `file` (binary, seekable, at its start), its
    header checked against the file's size before anything is allocated."""
    _check_header(file, "it", os.fstat(file.fileno()).st_size)
    file.seek(0)
    return np.lib.format.read_array(file, allow_pickle=False)


def _check_header(stream, what, size):
    """Read the .npy header of `stream` (`what` names it in errors, e.g. "its member
    'q.npy'"), `size` bytes in all; BadArchive unless its array is of plain data and its
    declared shape and type take exactly the bytes after the header."""
    try:
        version = np.lib.format.read_magic(stream)
        read_header = {(1, 0): np.lib.format.read_array_header_1_0,
                       (2, 0): np.lib.format.read_array_header_2_0}.get(version)
        if read_header is None:
            raise BadArchive(f"{what} has .npy format version {version}")
        shape, _, dtype = read_header(stream)
    except ValueError as err:
        raise BadArchive(f"{what} is not an .npy array ({err})") from None
    header = stream.tell()
    if dtype.hasobject:
        raise BadArchive(f"{what} holds Python objects (dtype {dtype}), which dmoc never "
                         "unpickles")
    declared = math.prod(shape) * dtype.itemsize
    if declared != size - header:
        raise BadArchive(f"{what} declares shape {shape} of {dtype} ({declared} bytes), but "
                         f"holds {size - header} bytes")
