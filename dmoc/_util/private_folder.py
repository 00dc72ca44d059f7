"""Folders only this user can change, for files whose content dmoc trusts (compiled code it
loads): a folder is created mode 0700 whatever the umask, and an existing one is accepted
only when this process's effective uid (`os.geteuid`: the owner of the files it creates;
no passwd entry needed, and a set-uid process never trusts its caller's folder) owns it,
neither group
nor others can write it, and every folder above it belongs to this uid or root and is
writable by nobody else unless it has the sticky bit (as /tmp), so no other account can put
a file into it, or replace it or one of its parents by a folder of its own.
"""

import os
import stat

from ..errors import CompiledCodeError

MODE = 0o700


def private_folder(path):
    """The real path of folder `path`, created with its missing parents (mode 0700) when it
    does not exist; `CompiledCodeError` naming the folder when another account can change
    what is in it (see the module notes) or it cannot be created."""
    path = os.path.realpath(path)
    try:
        _make(path)
    except OSError as err:
        raise CompiledCodeError(f"cannot create the folder {path}: {err.strerror}.") from None
    info = os.stat(path)
    if not stat.S_ISDIR(info.st_mode):
        raise CompiledCodeError(f"{path} is not a folder.")
    if info.st_uid != os.geteuid():
        raise CompiledCodeError(f"the folder {path} belongs to uid {info.st_uid}, not to this "
                                f"process's uid {os.geteuid()}: dmoc loads no code from it.")
    if info.st_mode & 0o022:
        raise CompiledCodeError(f"the folder {path} is writable by group or others (mode "
                                f"{stat.S_IMODE(info.st_mode):04o}): dmoc loads no code from "
                                f"it; make it private with `chmod 700 {path}`.")
    _check_parents(path)
    return path


def _make(path):
    """Create `path` and its missing parents, each mode 0700 (chmod after mkdir, so the
    umask does not widen it); an existing folder is left as it is."""
    missing = []
    while not os.path.lexists(path):
        missing.append(path)
        path = os.path.dirname(path)
    for folder in reversed(missing):
        try:
            os.mkdir(folder, MODE)
        except FileExistsError:       # made by someone else meanwhile: checked by the caller
            continue
        os.chmod(folder, MODE)


def _check_parents(path):
    """Refuse when a folder above `path` is another account's (not root's) or writable by
    others without the sticky bit: that account could move `path` away and put its own."""
    parent = os.path.dirname(path)
    while True:
        info = os.stat(parent)
        mode = info.st_mode
        if info.st_uid not in (0, os.geteuid()) or (mode & 0o022 and not mode & stat.S_ISVTX):
            raise CompiledCodeError(
                f"the folder {parent} above {path} belongs to uid {info.st_uid} with mode "
                f"{stat.S_IMODE(mode):04o}: another account could replace {path}, so dmoc "
                "loads no code from it.")
        if parent == os.path.dirname(parent):
            return
        parent = os.path.dirname(parent)
