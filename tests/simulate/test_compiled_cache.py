"""The compiled-step cache loads only what this user compiled (docs/stages/simulate.md,
"The compiled-step cache"): a library planted in a folder another account can write is never
loaded (its constructor would write a marker file); a truncated or zeroed library is
compiled again instead of crashing the process; a cache that cannot be used costs one
warning and the virtual machine with ``jit=None``, a clear error with ``jit=True``; two
processes compiling the same step at once both succeed; a uid without a passwd entry and a
umask of 000 work. Runs that load libraries run in child processes (a crash there is a
return code, not a dead test run), each against the virtual machine's trajectory computed
here (``jit=None`` before anything is compiled: no C involved, the Functions the library
is made from)."""

import hashlib
import json
import os
import stat
import pwd
import shutil
import subprocess
import sys
import tempfile
import time

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.errors import CompiledCodeError
from dmoc._util import cache_folder, compiled
from dmoc.simulation import stepper

pytestmark = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NOBODY, UNLISTED = 65534, 54321        # another account; a uid without a passwd entry
STEPS = 40

CHILD = """
import json, os, warnings
import dmoc
from dmoc.simulation import stepper
stepper.NATIVE_AFTER_SECONDS = 0.0          # jit=None: go native at the first chunk
disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
{drop}
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    try:
        runs = [dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps={steps}, jit={jit})
                for _ in range(2)]
        report = {{"success": all(r.success for r in runs), "native": runs[-1].stats["native"],
                   "q": runs[-1].trajectory.q.tolist()}}
    except dmoc.CompiledCodeError as err:
        report = {{"error": str(err)}}
report["warnings"] = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
print(json.dumps(report))
"""


def readable_by_others(path):
    """True when a uid without privileges can read `path`: every folder above it lets
    others through (o+x) and `path` lets them read (o+r)."""
    path = os.path.abspath(path)
    while True:
        mode = os.stat(path).st_mode
        if not mode & (stat.S_IXOTH if os.path.isdir(path) else stat.S_IROTH):
            return False
        if path == os.path.dirname(path):
            return True
        path = os.path.dirname(path)


def needs_other_uid():
    """Skip unless another uid can run CasADi here: once the child runs as that uid it
    loads CasADi's plugins and its compiler reads CasADi's headers from the installed
    package (a virtual environment inside a private folder, e.g. one made by mktemp,
    keeps them from it)."""
    package = os.path.join(os.path.dirname(ca.__file__), "include")
    if not readable_by_others(package):
        pytest.skip(f"another uid cannot read the installed CasADi package ({package}): a "
                    f"private folder is above it")


def child(jit, env, uid=None, umask=None, wait=True):
    """Run CHILD (two simulations) in a new process with `env` added to (or, where a value
    is None, removed from) this one's; the simulations run as `uid` (all its ids, set once
    the system is built: the interpreter's standard library is only root's to read) and
    under `umask`. Its JSON report, or the Popen when not `wait`."""
    full = {**os.environ, "PYTHONPATH": ROOT}
    for name, value in env.items():
        full.pop(name, None) if value is None else full.__setitem__(name, str(value))
    if uid is not None:
        needs_other_uid()
    drop = ([] if uid is None else [f"os.setgroups([]); os.setgid({uid}); os.setuid({uid})"]) + (
        [] if umask is None else [f"os.umask({umask})"])
    code = CHILD.format(jit=jit, steps=STEPS, drop="; ".join(drop))
    process = subprocess.Popen([sys.executable, "-c", code], env=full, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, cwd=tempfile.gettempdir())
    return finish(process) if wait else process


def finish(process):
    out, err = process.communicate(timeout=300)
    assert process.returncode == 0, f"child ended with {process.returncode}:\n{err}"
    return json.loads(out)


@pytest.fixture(scope="module")
def vm_q(tmp_path_factory):
    """The knife edge's positions from the virtual machine (no compiled code), with the
    Functions the compiled library is made from: the default's (jit=None) before anything
    is compiled or cached and before its switch (jit=False's lighter Functions agree to
    round-off only)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("DMOC_CACHE_DIR", str(tmp_path_factory.mktemp("empty-cache")))
        patch.setattr(stepper, "NATIVE_AFTER_SECONDS", float("inf"))
        dmoc.clear_caches("steppers")
        run = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=STEPS, jit=None)
        dmoc.clear_caches("steppers")
    assert run.stats["native"] is False
    return run.trajectory.q


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """(prefix, bytes) of the step's library, compiled by a child in a scratch cache: what
    anyone can compute from the public code."""
    where = tmp_path_factory.mktemp("scratch") / "cache"
    assert child(True, {"DMOC_CACHE_DIR": where})["native"] is True
    (library,) = where.glob("dirac_step-*.so")
    return library.name.rsplit("-", 1)[0], library.read_bytes()


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    """A real shared object whose constructor writes the file named in it; (bytes, marker)."""
    where = tmp_path_factory.mktemp("plant")
    marker = where / "marker"
    source = where / "plant.c"
    source.write_text('#include <stdio.h>\n__attribute__((constructor)) static void plant(void)'
                      f' {{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    subprocess.run([compiled.compiler(), "-shared", "-fPIC", str(source), "-o",
                    str(where / "plant.so")], check=True)
    return (where / "plant.so").read_bytes(), marker


def put(folder, prefix, data):
    """Write `data` into `folder` under the name dmoc gives a library of these bytes."""
    path = folder / f"{prefix}-{hashlib.sha256(data).hexdigest()}.so"
    path.write_bytes(data)
    return path


@pytest.fixture
def shared_tmp():
    """A folder in the system's temporary folder that other uids can traverse (pytest's
    tmp_path is private to root)."""
    path = tempfile.mkdtemp()
    os.chmod(path, 0o755)
    yield path
    shutil.rmtree(path)


def check_vm_fallback(report, vm_q, what):
    """The run succeeded in the virtual machine with exactly one warning naming `what`."""
    assert report["success"] and report["native"] is False
    assert len(report["warnings"]) == 1 and what in report["warnings"][0]
    np.testing.assert_array_equal(report["q"], vm_q)


# --- a library planted by another account ----------------------------------------------------

@pytest.mark.parametrize("how", ["world-writable", "group-writable", "another uid's"])
def test_a_library_planted_where_another_account_can_write_is_never_loaded(
        tmp_path, good, plant, vm_q, how):
    data, marker = plant
    folder = tmp_path / "cache"
    folder.mkdir()
    planted = put(folder, good[0], data)
    if how == "another uid's":
        os.chmod(folder, 0o755)
        os.chown(folder, NOBODY, NOBODY)
    else:
        os.chmod(folder, 0o777 if how == "world-writable" else 0o770)
    for jit in (None, True):
        report = child(jit, {"DMOC_CACHE_DIR": folder})
        if jit:
            assert "loads no code" in report["error"] and str(folder) in report["error"]
        else:
            check_vm_fallback(report, vm_q, "loads no code")
    assert not marker.exists() and planted.exists()


def test_the_same_plant_in_a_private_folder_is_loaded_so_the_name_is_the_one_looked_for(
        tmp_path, good, plant, vm_q):
    """The control of the test above: without the folder check the plant runs."""
    data, marker = plant
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    planted = put(folder, good[0], data)
    report = child(None, {"DMOC_CACHE_DIR": folder})
    assert marker.exists()
    marker.unlink()
    check_vm_fallback(report, vm_q, "does not hold the compiled")    # not the step: removed
    assert not planted.exists()


def test_a_parent_folder_others_can_write_refuses_the_cache(tmp_path, good, vm_q):
    parent = tmp_path / "open"
    parent.mkdir()
    os.chmod(parent, 0o777)                   # no sticky bit: anyone may rename the cache
    report = child(None, {"DMOC_CACHE_DIR": parent / "cache"})
    check_vm_fallback(report, vm_q, f"the folder {parent} above")


@pytest.mark.skipif(os.geteuid() != 0, reason="gives a folder to another account (chown)")
def test_a_parent_folder_of_another_account_refuses_the_cache(tmp_path, monkeypatch):
    """A folder above the cache that belongs to another account (not root), even one only
    it can write (0755): that account could move the cache away and put its own, so no
    library is compiled or loaded there; the same folder given back to this uid works."""
    parent = tmp_path / "theirs"
    parent.mkdir(mode=0o755)
    os.chown(parent, NOBODY, NOBODY)
    monkeypatch.setenv("DMOC_CACHE_DIR", str(parent / "cache"))
    x = ca.SX.sym("x")
    library = compiled.Library([ca.Function("f", [x], [2 * x])], "tiny")
    with pytest.raises(CompiledCodeError, match=f"the folder {parent} above .* belongs to uid {NOBODY}"):
        library.load()
    assert not list(parent.rglob("*.so"))
    os.chown(parent, os.geteuid(), os.getegid())
    assert float(library.load()["f"](3.0)) == 6.0


# --- damaged libraries -----------------------------------------------------------------------

DAMAGE = {
    "truncated to 10 %": lambda data: data[:len(data) // 10],
    "truncated to 50 %": lambda data: data[:len(data) // 2],
    "truncated to 85 %": lambda data: data[:len(data) * 85 // 100],
    "64 bytes zeroed": lambda data: data[:len(data) // 2] + bytes(64) + data[len(data) // 2 + 64:],
}


@pytest.mark.parametrize("jit", [None, True])
@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_library_is_compiled_again_never_a_crash(tmp_path, good, vm_q, damage, jit):
    prefix, data = good
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    damaged = folder / f"{prefix}-{hashlib.sha256(data).hexdigest()}.so"
    damaged.write_bytes(DAMAGE[damage](data))          # the name of the good library
    report = child(jit, {"DMOC_CACHE_DIR": folder})
    assert report["success"] and report["native"] is True and not report["warnings"]
    np.testing.assert_array_equal(report["q"], vm_q)
    (library,) = folder.glob("*.so")
    assert library.read_bytes() == data


def test_a_library_of_another_step_under_this_name_is_replaced(tmp_path, monkeypatch):
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path / "cache"))
    x = ca.SX.sym("x", 2)
    wanted = compiled.Library([ca.Function("f", [x], [2 * x])], "tiny")
    other = compiled.Library([ca.Function("f", [x[0]], [3 * x[0]])], "tiny")
    other.load()
    (library,) = (tmp_path / "cache").glob("tiny-*.so")
    data = library.read_bytes()
    library.unlink()
    put(tmp_path / "cache", wanted.prefix, data)
    with pytest.raises(CompiledCodeError, match="does not hold the compiled 'f'"):
        wanted.load()
    assert not list((tmp_path / "cache").glob("*.so"))
    np.testing.assert_array_equal(np.array(wanted.load()["f"]([1.0, 2.0])).ravel(), [2.0, 4.0])


# --- a cache that cannot be used -------------------------------------------------------------

def test_an_unwritable_cache_folder_falls_back_with_one_warning(shared_tmp, vm_q):
    folder = os.path.join(shared_tmp, "cache")
    os.mkdir(folder, 0o500)                 # the user's own, private, but read-only
    os.chown(folder, UNLISTED, UNLISTED)
    report = child(None, {"DMOC_CACHE_DIR": folder}, uid=UNLISTED)
    check_vm_fallback(report, vm_q, "Permission denied")
    report = child(True, {"DMOC_CACHE_DIR": folder}, uid=UNLISTED)
    assert "Permission denied" in report["error"]


def test_a_cache_that_cannot_be_created_falls_back_with_one_warning(tmp_path, vm_q):
    (tmp_path / "file").write_text("")
    report = child(None, {"DMOC_CACHE_DIR": tmp_path / "file" / "cache"})
    check_vm_fallback(report, vm_q, "cannot create")


def test_no_home_and_a_fallback_folder_made_by_another_account(tmp_path, vm_q):
    (tmp_path / "file").write_text("")
    taken = tmp_path / f"dmoc-{os.getuid()}"
    taken.mkdir(mode=0o755)
    os.chown(taken, NOBODY, NOBODY)
    env = {"DMOC_CACHE_DIR": None, "XDG_CACHE_HOME": None, "HOME": tmp_path / "file",
           "TMPDIR": tmp_path}
    report = child(None, env)
    check_vm_fallback(report, vm_q, f"the folder {taken} belongs to uid {NOBODY}")


def test_a_uid_without_a_passwd_entry_works(shared_tmp, vm_q):
    with pytest.raises(KeyError):
        pwd.getpwuid(UNLISTED)
    os.chown(shared_tmp, UNLISTED, UNLISTED)
    os.chmod(shared_tmp, 0o700)
    env = {"DMOC_CACHE_DIR": None, "XDG_CACHE_HOME": None, "HOME": None, "TMPDIR": shared_tmp}
    report = child(True, env, uid=UNLISTED)
    assert report["success"] and report["native"] is True and not report["warnings"]
    np.testing.assert_array_equal(report["q"], vm_q)
    folder = os.path.join(shared_tmp, f"dmoc-{UNLISTED}")
    assert len([n for n in os.listdir(folder) if n.endswith(".so")]) == 1


def test_under_umask_000_the_folder_and_libraries_are_private(shared_tmp, vm_q):
    os.chown(shared_tmp, UNLISTED, UNLISTED)
    folder = os.path.join(shared_tmp, "a", "cache")
    report = child(True, {"DMOC_CACHE_DIR": folder}, uid=UNLISTED, umask=0)
    assert report["success"] and report["native"] is True
    paths = [os.path.join(shared_tmp, "a"), folder,
             *(os.path.join(folder, name) for name in os.listdir(folder))]
    assert len(paths) == 3 and all(os.stat(p).st_mode & 0o077 == 0 for p in paths)


# --- concurrency, keys, temporary folders, the size bound -------------------------------------

def test_two_processes_compiling_the_same_step_at_once_both_succeed(tmp_path, vm_q):
    folder = tmp_path / "cache"
    processes = [child(True, {"DMOC_CACHE_DIR": folder}, wait=False) for _ in range(2)]
    for report in map(finish, processes):
        assert report["success"] and report["native"] is True and not report["warnings"]
        np.testing.assert_array_equal(report["q"], vm_q)
    names = os.listdir(folder)
    assert names and all(n.endswith(".so") for n in names)        # no temporary folder left
    for name in names:
        digest = hashlib.sha256((folder / name).read_bytes()).hexdigest()
        assert name.rsplit("-", 1)[1] == digest + ".so"


def _tiny(scale=2.0):
    x = ca.SX.sym("x", 2)
    return compiled.Library([ca.Function("f", [x], [scale * x])], "tiny")


def test_the_key_names_casadi_the_compiler_and_its_flags(tmp_path, monkeypatch):
    base = _tiny().prefix
    assert _tiny().prefix == base and _tiny(3.0).prefix != base
    monkeypatch.setattr(compiled, "FLAGS", (*compiled.FLAGS, "-march=native"))
    assert _tiny().prefix != base
    monkeypatch.undo()
    monkeypatch.setattr(compiled.ca, "__version__", "0.0.0")
    assert _tiny().prefix != base
    monkeypatch.undo()
    wrapper = tmp_path / "cc-wrapper"          # another compiler: the same cc, another --version
    wrapper.write_text(f'#!/bin/sh\n[ "$1" = --version ] && echo wrapper 1 && exit 0\n'
                       f'exec {compiled.compiler()} "$@"\n')
    wrapper.chmod(0o755)
    monkeypatch.setenv("CC", str(wrapper))
    assert _tiny().prefix != base


def test_a_failed_compile_leaves_no_temporary_folder_and_stale_ones_go(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    monkeypatch.setenv("DMOC_CACHE_DIR", str(folder))
    stale, fresh = folder / "tmpkilled", folder / "tmprunning"
    for path in (stale, fresh):
        path.mkdir()
        (path / "library.c").write_text("")
    old = time.time() - cache_folder.STALE_SECONDS - 60
    os.utime(stale, (old, old))
    monkeypatch.setenv("CC", shutil.which("false"))
    with pytest.raises(CompiledCodeError, match="failed"):
        _tiny().load()
    assert sorted(p.name for p in folder.iterdir()) == ["tmprunning"]
    monkeypatch.delenv("CC")
    _tiny().load()
    assert sorted(p.suffix for p in folder.iterdir()) == ["", ".so"]


def test_least_recently_used_libraries_go_first_and_a_load_counts_as_a_use(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("DMOC_CACHE_DIR", str(folder))
    first, second = _tiny(2.0), _tiny(3.0)
    first.load(), second.load()
    (a,), (b,) = folder.glob(first.prefix + "-*"), folder.glob(second.prefix + "-*")
    os.utime(a, ns=(1, a.stat().st_mtime_ns))           # a used long ago, b a little later
    os.utime(b, ns=(2, b.stat().st_mtime_ns))
    stamp = a.stat().st_mtime_ns
    assert first.cached()                                # a use: a is now the newest
    assert a.stat().st_atime_ns > 2 and a.stat().st_mtime_ns == stamp
    third = _tiny(4.0)
    monkeypatch.setenv("DMOC_CACHE_MAX_BYTES", str(a.stat().st_size * 5 // 2))
    third.load()                                         # 3 libraries of about equal size
    assert a.exists() and not b.exists() and len(list(folder.glob("tiny-*.so"))) == 2
    monkeypatch.setenv("DMOC_CACHE_MAX_BYTES", "0")
    _tiny(5.0).load()                                    # the new one is always kept
    assert [p.name.startswith(_tiny(5.0).prefix) for p in folder.glob("*.so")] == [True]


def test_a_bad_size_bound_is_named(tmp_path, monkeypatch):
    monkeypatch.setenv("DMOC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("DMOC_CACHE_MAX_BYTES", "lots")
    with pytest.raises(CompiledCodeError, match="`DMOC_CACHE_MAX_BYTES` must be"):
        _tiny().load()
    assert not list((tmp_path / "cache").iterdir())      # refused before compiling
