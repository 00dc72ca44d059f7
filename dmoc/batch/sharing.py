"""How the packed trajectories of a chunk of `simulate_many` (`dmoc.batch.packing`) reach
a client on the same machine as their worker: through a file of shared memory instead of
Dask's TCP frames, which cost about a quarter of a batch of 1000 runs of 1000 steps
(docs/performance.md, "Fourth round").

The client owns the exchange (`Exchange`): for the length of a batch it keeps a beacon,
an empty file of its own in `FOLDER` with a random name. A worker that sees the beacon,
owned by its own user, shares that folder with the client: it writes the chunk's arrays
into a new file next to it (created exclusively, mode 0600) and sends only its name and
layout. Any other worker (another machine, a container with its own /dev/shm, another
user) and any chunk under `MIN_BYTES` sends the arrays through Dask as before. The client
maps the file copy-on-write after checking that its own user owns it, that no one else
may write it, and that its size is the layout's, then removes it at once. The file holds
numbers only: nothing in it is unpickled or run. At the end of the batch the client
removes the beacon and then every file left with its prefix (chunks whose results never
arrived); a worker that finds the beacon gone after creating its file removes the file
itself, so no file outlives the batch whatever its order of events, unless the client's
process is killed.
"""

import glob
import mmap
import os
import secrets
import stat

import numpy as np

FOLDER = "/dev/shm"

# Chunks whose arrays are smaller travel through Dask: a file costs a few system calls.
MIN_BYTES = 1 << 20


class Exchange:
    """The client's side of one batch: ``with Exchange() as share:`` gives the value
    (beacon path, MIN_BYTES) a worker's `SharedFile` takes, or None where `FOLDER` cannot be
    used; on exit the beacon and every file left of the batch are removed."""

    def __init__(self):
        self.prefix = os.path.join(FOLDER, f"dmoc-batch-{secrets.token_hex(12)}")

    def __enter__(self):
        try:
            os.close(os.open(self.prefix, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW,
                             0o600))
        except OSError:            # no shared-memory folder here: Dask carries everything
            return None
        return self.prefix, MIN_BYTES

    def __exit__(self, *exc):
        for path in [self.prefix, *glob.glob(glob.escape(self.prefix) + "-*")]:
            try:
                os.unlink(path)
            except OSError:
                pass


class SharedFile:
    """A worker's file for the arrays of one chunk (`allocate`), when `share`, the
    client's `Exchange`, reaches this worker and the arrays reach `MIN_BYTES`. `path`
    and `layout` name the file once `seal` has kept it:
    ``layout[name] = (offset, dtype, shape)``."""

    def __init__(self, share):
        self.share, self.path, self.layout = share, None, None

    def allocate(self, shapes):
        """{name: writable array of shapes[name] = (shape, dtype)} in a new file of the
        client's folder (created exclusively, mode 0600), or None where there is none."""
        layout, offset = {}, 0
        for name, (shape, dtype) in shapes.items():
            layout[name] = (offset, np.dtype(dtype).str, tuple(shape))
            offset += np.dtype(dtype).itemsize * int(np.prod(shape))
        memory = self._file(offset)
        if memory is None:
            return None
        self.layout = layout
        return {name: _view(memory, *layout[name]) for name in layout}

    def seal(self):
        """Whether the arrays went to a file the client will read: its batch is still on
        (the beacon is there); otherwise the file is removed."""
        if self.path is None:
            return False
        if os.path.exists(self.share[0]):
            return True
        os.unlink(self.path)
        self.path = None
        return False

    def _file(self, size):
        """A shared mapping of a new file of `size` bytes next to the beacon, or None."""
        if self.share is None:
            return None
        beacon, min_bytes = self.share
        if size < max(min_bytes, 1) or not _own(beacon):
            return None
        path = f"{beacon}-{secrets.token_hex(8)}"
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        except OSError:
            return None
        try:
            # reserved, not only sized: a full /dev/shm (64 MB in a Docker container by
            # default) then fails here instead of killing the worker with SIGBUS later
            os.posix_fallocate(fd, 0, size)
            memory = mmap.mmap(fd, size)
        except OSError:
            os.unlink(path)
            return None
        finally:
            os.close(fd)
        self.path = path
        return memory


def read(path, layout):
    """The arrays a `SharedFile` put in the file `path`, as copy-on-write views of its memory;
    the file is removed. Raises OSError when the file is not one the worker of this
    user wrote for this layout (nor any path outside `FOLDER`'s batch files)."""
    if (os.path.dirname(path) != FOLDER
            or not os.path.basename(path).startswith("dmoc-batch-")):
        raise OSError(f"{path} is not a file of this user's batch")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    finally:
        if os.path.lexists(path):
            os.unlink(path)
    try:
        info = os.fstat(fd)
        size = max((offset + np.dtype(dtype).itemsize * int(np.prod(shape))
                    for offset, dtype, shape in layout.values()), default=0)
        if (not stat.S_ISREG(info.st_mode) or info.st_uid != os.getuid()
                or info.st_mode & 0o077 or info.st_size != size):
            raise OSError(f"{path} is not a file of this user's batch of the expected size")
        memory = mmap.mmap(fd, size, access=mmap.ACCESS_COPY)
    finally:
        os.close(fd)
    return {name: _view(memory, offset, np.dtype(dtype), shape)
            for name, (offset, dtype, shape) in layout.items()}


def _own(path):
    """Whether `path` exists and belongs to this process's user."""
    try:
        return os.stat(path, follow_symlinks=False).st_uid == os.getuid()
    except OSError:
        return False


def _view(memory, offset, dtype, shape):
    return np.frombuffer(memory, dtype, int(np.prod(shape)), offset).reshape(shape)
