"""The files of the compiled-code cache (docs/stages/simulate.md, "The compiled-step cache"):
what is hashed is what is loaded (the file rewritten between the check and the load does
not change what runs), a foreign file (another uid's, a hard link) is removed with one
warning instead of failing, and a compile on a full disk says so instead of reporting the
compiler's syntax error on a cut source."""

import hashlib
import os
import subprocess
import warnings

import casadi as ca
import numpy as np
import pytest

from dmoc.errors import CompiledCodeError
from dmoc._util import compiled

pytestmark = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")
NOBODY = 65534


def tiny(scale=2.0):
    x = ca.SX.sym("x", 2)
    return compiled.Library([ca.Function("f", [x], [scale * x])], "tiny")


def twice(library):
    return np.array(library.load()["f"]([1.0, 2.0])).ravel().tolist()


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("DMOC_CACHE_DIR", str(folder))
    return folder


def test_a_library_rewritten_between_its_check_and_its_load_runs_what_was_checked(
        cache, tmp_path, monkeypatch):
    """The file is replaced by a plant (with its constructor writing a marker) right before
    `casadi.external` runs: the bytes loaded are the ones hashed, the plant never runs."""
    library = tiny()
    assert twice(library) == [2.0, 4.0]
    marker = tmp_path / "marker"
    source = tmp_path / "plant.c"
    source.write_text('#include <stdio.h>\n__attribute__((constructor)) static void plant(void)'
                      f' {{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    plant = tmp_path / "plant.so"
    subprocess.run([compiled.compiler(), "-shared", "-fPIC", str(source), "-o", str(plant)],
                   check=True)
    (path,) = cache.glob("tiny-*.so")
    external = ca.external

    def swapped(*args):
        path.write_bytes(plant.read_bytes())       # the same file, rewritten in place
        return external(*args)

    monkeypatch.setattr(compiled.ca, "external", swapped)
    fresh = tiny(2.0)                               # the same key and library, loaded anew
    assert twice(fresh) == [2.0, 4.0]
    assert not marker.exists()


@pytest.mark.parametrize("how", ["another uid's", "a hard link"])
def test_a_foreign_file_in_the_cache_is_removed_with_one_warning(cache, tmp_path, how):
    library = tiny()
    twice(library)
    (path,) = cache.glob("tiny-*.so")
    if how == "another uid's":
        if os.geteuid() != 0:
            pytest.skip("giving a file to another uid needs root")
        os.chown(path, NOBODY, NOBODY)
    else:
        os.link(path, tmp_path / "elsewhere.so")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert twice(tiny()) == [2.0, 4.0]          # compiled again
        assert twice(tiny()) == [2.0, 4.0]
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1 and path.name in messages[0] and "removed" in messages[0]
    assert ("belongs to uid 65534" if how == "another uid's" else "has 2 links") in messages[0]
    (again,) = cache.glob("tiny-*.so")
    assert os.stat(again).st_nlink == 1 and os.stat(again).st_uid == os.geteuid()
    assert again.name.rsplit("-", 1)[1] == hashlib.sha256(again.read_bytes()).hexdigest() + ".so"


@pytest.fixture
def full_disk(tmp_path):
    """A folder on a 64 KiB file system, nearly filled (root only: it is mounted)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a small file system needs root")
    where = tmp_path / "small"
    where.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(where)]).returncode:
        pytest.skip("this machine cannot mount a tmpfs")
    yield where
    subprocess.run(["umount", str(where)], check=True)


@pytest.mark.parametrize("left", [2048, 16 * 1024])
def test_a_compile_on_a_full_disk_says_the_disk_is_full(full_disk, monkeypatch, left):
    """`left` bytes free: the source is cut short (2 KiB) or the source fits and the library does not (16 KiB)."""
    monkeypatch.setenv("DMOC_CACHE_DIR", str(full_disk / "cache"))
    filler = full_disk / "filler"
    with open(filler, "wb") as file:
        file.write(bytes(64 * 1024 - left))
    x = ca.SX.sym("x", 40)
    big = compiled.Library([ca.Function("f", [x], [ca.sin(x) * ca.cos(x.T @ x)])], "big")
    with pytest.raises(CompiledCodeError, match="disk is full") as info:
        big.load()
    assert "syntax" not in str(info.value).split("\n")[0]
    filler.unlink()
    assert np.isfinite(np.array(big.load()["f"](np.ones(40)))).all()


def test_a_link_met_on_the_walk_is_refused_even_to_a_folder_of_this_uid(tmp_path, monkeypatch):
    """A link that appears on the path after it was resolved (another account swapping it)
    is refused, not followed, even when it leads to a private folder of this uid: the
    folder the caller checked must be the one it uses. Simulated by a path whose resolution
    is skipped (the race's window)."""
    from dmoc._util import private_folder as folders
    mine = tmp_path / "mine"
    mine.mkdir(mode=0o700)
    (tmp_path / "swapped").symlink_to(mine)
    monkeypatch.setattr(folders.os.path, "realpath", lambda path: str(path))
    with pytest.raises(CompiledCodeError, match="is a link"):
        folders.private_folder(tmp_path / "swapped")
