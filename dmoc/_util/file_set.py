"""A set of files in a folder (one command-line run's outputs) replaced by another in one
atomic step, so that a process killed at any instruction leaves the old set or the new
one, byte for byte. The files stay where a user looks for them, each ``OUT/FILE`` a
symbolic link into the set's hidden folder, whose link ``current`` names the version shown:

    OUT/FILE -> .NAME.dmoc/current/FILE      one link per file of the set, made once
    OUT/.NAME.dmoc/current -> v<hex>         the one switch: a new link renamed over it
    OUT/.NAME.dmoc/v<hex>/FILE               the files of one version

A new set is written into a new version folder beside the current one; links are made
for its new names (they point at nothing until the switch: the old set has no such file);
then ``current`` is switched by one rename; then the links of names the new set lacks and
the other version folders are removed (a kill there leaves only dangling links and a
folder that the next run removes). Regular files at the set's names (written by a dmoc
before this layout, or a kill during this step) are first taken into the current version
by a hard link, then replaced by their link, which shows the same bytes.
"""

import contextlib
import os
import secrets

CURRENT = "current"


def temporary_name(name, suffix=""):
    """The hidden name ``.NAME.PID.HEX.tmp[SUFFIX]`` of a temporary for `name`, the one
    `dmoc._util.files` sweeps when a process left it behind (see its module notes)."""
    return f".{name}.{os.getpid()}.{secrets.token_hex(6)}.tmp{suffix}"


def hidden_folder(name):
    """The name of the hidden folder of the set `name` in its folder."""
    return f".{name}.dmoc"


def replace(out, name, stage, replaced=()):
    """Make the files of folder `stage` (inside `out`, the same file system) the set `name`
    of folder `out`, in place of its earlier files and of the regular files `replaced`
    there (names an earlier run may have written), in one atomic step (see the module
    notes); `stage` is left empty."""
    base = os.path.join(out, hidden_folder(name))
    with contextlib.suppress(FileExistsError):
        os.mkdir(base)
    new = sorted(os.listdir(stage))
    link_target = os.path.join(hidden_folder(name), CURRENT)
    current = _current(base)
    for file in dict.fromkeys([*new, *replaced]):
        _adopt(out, base, current, file, link_target)
    version = "v" + secrets.token_hex(8)
    os.mkdir(os.path.join(base, version))
    made = []
    try:
        for file in new:
            os.replace(os.path.join(stage, file), os.path.join(base, version, file))
        _fsync(os.path.join(base, version))
        for file in new:
            if _link(os.path.join(link_target, file), os.path.join(out, file)):
                made.append(file)
        _fsync(out)
        _link(version, os.path.join(base, CURRENT))      # the switch
    except BaseException:       # the old set stays shown; what this call made goes
        _undo(out, base, version, made)
        raise
    _fsync(base)
    with contextlib.suppress(OSError):      # the next run finishes what a failure here left
        _clean(out, base, version, link_target)


def _undo(out, base, version, made):
    """Remove the new `version` folder of `base` and the links `made` in `out` for names
    the shown set lacks."""
    for file in made:
        path = os.path.join(out, file)
        if not os.path.exists(path):
            os.unlink(path)
    _remove_folder(os.path.join(base, version))


def _current(base):
    """The version folder `current` names in `base`, made empty when there is none."""
    try:
        return os.readlink(os.path.join(base, CURRENT))
    except FileNotFoundError:
        version = "v" + secrets.token_hex(8)
        os.mkdir(os.path.join(base, version))
        _link(version, os.path.join(base, CURRENT))
        return version


def _adopt(out, base, current, file, link_target):
    """When ``out/file`` is a regular file, put it into the current version (a hard link)
    and replace it by its link to there: the same bytes shown."""
    path = os.path.join(out, file)
    if os.path.islink(path) or not os.path.isfile(path):
        return
    kept = os.path.join(base, current, file)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(kept)                  # an earlier, killed adoption's
    os.link(path, kept)
    _link(os.path.join(link_target, file), path)


def _link(target, path):
    """Make `path` a symbolic link to `target` in one rename (a link already right stays);
    whether it was made."""
    with contextlib.suppress(OSError):
        if os.readlink(path) == target:
            return False
    folder, name = os.path.split(path)      # a hidden name the next run's sweep knows
    temporary = os.path.join(folder, temporary_name(name))
    os.symlink(target, temporary)
    try:
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise
    return True


def _clean(out, base, version, link_target):
    """After the switch to `version`: remove the links of `out` into the set that point at
    no file (names the new set lacks) and every other version folder."""
    prefix = link_target + os.sep
    for entry in os.scandir(out):
        if entry.is_symlink() and os.readlink(entry.path).startswith(prefix) and not \
                os.path.exists(entry.path):
            os.unlink(entry.path)
    for entry in os.scandir(base):      # other versions, and links a kill left half made
        if entry.name in (version, CURRENT):
            continue
        if entry.is_dir(follow_symlinks=False):
            _remove_folder(entry.path)
        else:
            os.unlink(entry.path)


def _remove_folder(folder):
    """Remove the version folder `folder` and its files."""
    for file in os.listdir(folder):
        os.unlink(os.path.join(folder, file))
    os.rmdir(folder)


def _fsync(folder):
    """Flush the entries of `folder` to disk."""
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
