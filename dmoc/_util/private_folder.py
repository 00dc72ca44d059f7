"""Folders only this user can change, for files whose content dmoc trusts (compiled code it
loads), opened as a descriptor that no later change of a path can redirect. The path is
walked from the root one folder at a time, each opened with ``O_NOFOLLOW | O_DIRECTORY``
relative to the one above and checked with `os.fstat` on that descriptor: every folder
above belongs to this process's effective uid (`os.geteuid`: the owner of the files it
creates; no passwd entry needed, and a set-uid process never trusts its caller's folder)
or root and is writable by nobody else unless it has the sticky bit (as /tmp), and the
folder itself belongs to this uid and neither group nor others can write it. A missing
folder is created (mode 0700 whatever the umask) relative to its parent's descriptor. A
link met on the walk (the path changed after it was resolved: another account swapping
it) is refused, never followed, so another account can neither put a file into the folder
nor make dmoc use a folder of its own instead.
"""

import errno
import os
import stat

from ..errors import CompiledCodeError

MODE = 0o700
_FOLDER = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)


def private_folder(path):
    """(the real path of folder `path`, a descriptor of it opened for reading), the folder
    and its missing parents created (mode 0700) when it does not exist; the caller closes
    the descriptor. `CompiledCodeError` naming the folder when another account can change
    what is in it (see the module notes) or it cannot be created or opened."""
    path = os.path.realpath(path)
    parts = [part for part in path.split(os.sep) if part]
    descriptor = os.open(os.sep, _FOLDER)
    where = os.sep
    try:
        if parts:
            _check_parent(os.fstat(descriptor), where, path)
        for depth, part in enumerate(parts):
            below = _enter(descriptor, where, part, path, last=depth == len(parts) - 1)
            os.close(descriptor)
            descriptor, where = below, os.path.join(where, part)
        _check(os.fstat(descriptor), path)
    except BaseException:
        os.close(descriptor)
        raise
    return path, descriptor


def _enter(parent, where, name, path, last):
    """A descriptor of folder `name` in the folder `where` open as `parent` (checked: see
    the module notes), created mode 0700 when missing."""
    target = os.path.join(where, name)
    try:
        descriptor, created = _open_or_make(parent, name)
    except OSError as err:
        reason = ("it is a link that was not there when the path was resolved (changed "
                  "meanwhile), or not a folder" if err.errno in (errno.ELOOP, errno.ENOTDIR)
                  else err.strerror)
        raise CompiledCodeError(f"cannot create or open the folder {target}: {reason}.") from None
    try:
        info = os.fstat(descriptor)
        if created and info.st_uid == os.geteuid():
            os.fchmod(descriptor, MODE)     # the umask may have narrowed it, or (000) not
            info = os.fstat(descriptor)
        if not last:
            _check_parent(info, target, path)
    except BaseException:
        os.close(descriptor)
        raise
    return descriptor


def _open_or_make(parent, name):
    """(a descriptor of folder `name` in `parent`, whether it was created here)."""
    try:
        return os.open(name, _FOLDER, dir_fd=parent), False
    except FileNotFoundError:
        pass
    try:
        os.mkdir(name, MODE, dir_fd=parent)
    except FileExistsError:         # made by someone else meanwhile: checked by the caller
        return os.open(name, _FOLDER, dir_fd=parent), False
    return os.open(name, _FOLDER, dir_fd=parent), True


def _check(info, shown):
    """Refuse folder `shown` (fstat `info`) unless it is a folder of this uid that neither
    group nor others can write."""
    if not stat.S_ISDIR(info.st_mode):
        raise CompiledCodeError(f"{shown} is not a folder.")
    if info.st_uid != os.geteuid():
        raise CompiledCodeError(f"the folder {shown} belongs to uid {info.st_uid}, not to this "
                                f"process's uid {os.geteuid()}: dmoc loads no code from it.")
    if info.st_mode & 0o022:
        raise CompiledCodeError(f"the folder {shown} is writable by group or others (mode "
                                f"{stat.S_IMODE(info.st_mode):04o}): dmoc loads no code from "
                                f"it; make it private with `chmod 700 {shown}`.")


def _check_parent(info, where, path):
    """Refuse a folder `where` (fstat `info`) above the private `path` that is another
    account's (not root's) or writable by others without the sticky bit: that account could
    move what is below away and put its own."""
    mode = info.st_mode
    if info.st_uid not in (0, os.geteuid()) or (mode & 0o022 and not mode & stat.S_ISVTX):
        raise CompiledCodeError(
            f"the folder {where} above {path} belongs to uid {info.st_uid} with mode "
            f"{stat.S_IMODE(mode):04o}: another account could replace {path}, so dmoc loads "
            "no code from it.")
