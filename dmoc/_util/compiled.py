"""CasADi Functions compiled to C once and kept on disk, keyed by what they compute and how
they are compiled: the simulator's step horizons (`dmoc.simulation.stepper`) and, with
``jit=True``, the optimizer's NLP Functions (`dmoc.optimal_control.nlp.evaluation`). A library's key is the
SHA-256 of the serialized Functions, the CasADi version, the machine, the compiler (its
resolved path and its ``--version`` output) and its flags, so every process and every later
session loads the same code with `casadi.external` instead of compiling again; where no C
compiler exists, `compiler()` is None and callers keep CasADi's virtual machine, which
computes the same thing (`Library`).

The libraries live in a private folder worked through a descriptor; a library is loaded
from the very bytes that hashed to its name (a sealed anonymous file), and only when they
do and its Functions have the signatures of the ones asked for (`cache_folder`; the
threat model is in docs/stages/simulate.md). The compiler is ``$CC`` (default ``cc``, then
``gcc``); set ``CC`` to an empty string to disable compilation.
"""

import functools
import hashlib
import os
import platform
import secrets
import shutil
import subprocess
import threading

import casadi as ca

from ..errors import CompiledCodeError
from . import cache_folder, sealed_file

FLAGS = ("-O2", "-fPIC", "-shared")


def compiler():
    """Resolved path of the C compiler, or None when there is none (or ``CC`` is set empty).

    Found once per process for each value of ``CC`` and ``PATH`` (`shutil.which` and
    `os.path.realpath` cost 0.1 ms, on every `simulate` or `optimize` call with
    ``jit=True``), and found again when the file found then is no longer the same
    (another file, mode or modification time, e.g. a link moved to another compiler). A compiler put earlier on
    an unchanged ``PATH`` during the process is not seen; a missing compiler is looked for
    on every call."""
    key = (os.environ.get("CC"), os.environ.get("PATH"))
    found = _FOUND.get(key)
    if found is not None and _file_identity(found[0]) == found[1]:
        return found[2]
    candidates = (key[0],) if key[0] is not None else ("cc", "gcc")
    for candidate in candidates:
        path = shutil.which(candidate) if candidate else None
        if path:
            resolved = os.path.realpath(path)
            if os.path.isabs(path):         # a relative one depends on the working folder
                _FOUND[key] = (path, _file_identity(path), resolved)
            return resolved
    return None


_FOUND = {}     # (CC, PATH) -> (the path found, its `_file_identity`, its resolved path)


def _file_identity(path):
    """What tells the file at `path` (links followed) from another: device, inode, mode and
    modification time; None when there is none."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_mode, st.st_mtime_ns


@functools.lru_cache(maxsize=8)
def _identity(path, stamp):
    """What names compiler `path` (as found at modification time `stamp`) in a key: its path
    and the output of ``path --version`` (the path alone when that fails)."""
    try:
        done = subprocess.run([path, "--version"], capture_output=True, text=True,
                              check=False, timeout=30)
        version = done.stdout if done.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        version = ""
    return f"{path}\n{version}"


class Library:
    """The C library of CasADi `functions` (distinct names) in the cache folder, named
    ``<stem>-<key>-<sha256 of the file>.so``; `key` is the SHA-256 of what it computes and
    how it is compiled (see the module notes), None without a C compiler (`cc`)."""

    def __init__(self, functions, stem):
        self.functions, self.cc, self.key = list(functions), compiler(), None
        if self.cc is not None:
            digest = hashlib.sha256(
                f"casadi {ca.__version__}; {platform.machine()}; {' '.join(FLAGS)}; "
                f"{_identity(self.cc, os.stat(self.cc).st_mtime_ns)}".encode())
            for function in self.functions:
                digest.update(function.serialize().encode())
            self.key = digest.hexdigest()[:32]
        self.prefix = f"{stem}-{self.key}"

    def cached(self):
        """True when a verified library is in the cache folder (False also when there is no
        private folder: `load` says why)."""
        if self.key is None:
            return False
        try:
            with cache_folder.opened() as where:
                return cache_folder.verified(where, self.prefix) is not None
        except (CompiledCodeError, OSError):
            return False

    def load(self):
        """{name: Function} loaded with `casadi.external` from the verified library,
        compiled first when there is none; `CompiledCodeError` saying why when no library
        can be loaded safely."""
        if self.key is None:
            raise CompiledCodeError("no C compiler: nothing can be compiled (set CC to one).")
        try:
            with cache_folder.opened() as where:
                name, data = cache_folder.verified(where, self.prefix) or self._compile(where)
                return self._external(where, name, data)
        except OSError as err:
            raise CompiledCodeError(f"the compiled-code cache failed: {err}.") from None

    def _external(self, where, name, data):
        """The Functions of library `name` in the `cache_folder.Folder` `where`, loaded from
        its verified bytes `data` (`sealed_file`), each checked to have the signature
        (inputs, outputs and their sparsity) of the Function it stands for; a library that
        does not is removed and `CompiledCodeError` raised."""
        digest = name[len(self.prefix) + 1:-len(cache_folder.SUFFIX)]  # hashed by `verified`/`publish`
        path = (sealed_file.sealed_path(data, digest) if sealed_file.available()
                else os.path.join(where.path, name))
        loaded = {}
        for f in self.functions:
            try:
                g = ca.external(f.name(), path)
            except RuntimeError as err:
                g, reason = None, str(err).strip().splitlines()[-1]
            if g is None or not _same_signature(f, g):
                cache_folder.discard(where, name)
                raise CompiledCodeError(
                    f"{os.path.join(where.path, name)} does not hold the compiled {f.name()!r} "
                    "asked for" + (f" ({reason})" if g is None else "") + "; it was removed "
                    "and is compiled again on the next run.")
            loaded[f.name()] = g
        return loaded

    def _compile(self, where):
        """Generate and compile the library in a private temporary folder inside the
        `cache_folder.Folder` `where` (removed on every way out), worked through its
        descriptor (`_build`), and publish it (`cache_folder.publish`); (its name, its
        bytes). Temporary folders abandoned by killed compiles are removed first, and the
        least recently used libraries after, to keep the size bound
        (`cache_folder.max_bytes`)."""
        bound = cache_folder.max_bytes()
        cache_folder.remove_stale(where)
        work = "tmp" + secrets.token_hex(8)
        os.mkdir(work, 0o700, dir_fd=where.fd)
        try:
            fd = os.open(work, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW, dir_fd=where.fd)
            try:
                self._build(fd, os.path.join(where.path, work))
                name, data = cache_folder.publish(where, fd, "library.so", self.prefix)
            finally:
                os.close(fd)
        finally:
            shutil.rmtree(work, dir_fd=where.fd, ignore_errors=True)
        cache_folder.evict(where, name, bound)
        return name, data

    def _build(self, work, path):
        """Write the C source of the Functions into the folder open as `work` (at `path`)
        and compile it there into ``library.so``; where there is /proc (Linux), both address
        the folder as ``/proc/self/fd/N`` of the descriptor (the compiler is given it), so
        no path swapped meanwhile redirects them. A source cut short or a compile failed on
        a full disk is reported as such, not as the compiler's syntax error."""
        folder = (f"/proc/self/fd/{work}" if sealed_file.available() else path) + os.sep
        generator = ca.CodeGenerator("library.c", {"with_header": False})
        for function in self.functions:
            generator.add(function)
        source = generator.generate(folder)
        if generator.dump() not in _read_text(work, "library.c"):
            raise CompiledCodeError(f"the generated C source was cut short while written to "
                                    f"{path}{_disk_full(work)}.")
        done = subprocess.run([self.cc, *FLAGS, source, "-o", folder + "library.so", "-lm"],
                              capture_output=True, text=True, check=False, pass_fds=(work,))
        if done.returncode:
            raise CompiledCodeError(f"compiling the generated C with {self.cc} failed"
                                    f"{_disk_full(work)}:\n{done.stderr}")


class Background:
    """``load()``, which returns {name: Function} loaded by `Library.load`, run in a daemon
    thread, so that the caller goes on in CasADi's virtual machine meanwhile: `functions`
    is None until it has ended, then what `load` returned, or None for good when no
    library could be compiled or loaded safely (`Library.load`'s checks, in that thread).
    A process that ends while the compiler runs leaves its temporary folder in the cache
    folder, which the next compile removes (`Library._compile`)."""

    def __init__(self, load):
        self._done, self._functions = threading.Event(), None
        threading.Thread(target=self._run, args=(load,), name="dmoc-compile", daemon=True).start()

    def _run(self, load):
        try:
            self._functions = load()
        except (CompiledCodeError, OSError, RuntimeError):
            self._functions = None
        finally:
            self._done.set()

    @property
    def functions(self):
        """The loaded {name: Function}; None while the thread runs or when it failed."""
        return self._functions if self._done.is_set() else None

    def wait(self, timeout=None):
        """Wait until the thread has ended (at most `timeout` seconds); True if it has."""
        return self._done.wait(timeout)


def _read_text(folder, name):
    """The text of file `name` in the folder open as `folder`."""
    fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW, dir_fd=folder)
    with os.fdopen(fd, encoding="utf-8", errors="replace") as file:
        return file.read()


def _disk_full(folder):
    """", its disk is full (...)" when the disk of the folder open as `folder` has less
    than 1 MiB free (a cut source or a failed compile is then no fault of the code), else
    ""."""
    info = os.fstatvfs(folder)
    free = info.f_bavail * info.f_frsize
    if free >= 1 << 20:
        return ""
    return (f": its disk is full ({free} bytes free); free some space or set DMOC_CACHE_DIR "
            "to a folder on another disk")


def _same_signature(f, g):
    """True when Functions `f` and `g` have the same inputs and outputs (sparsity included)."""
    if (f.n_in(), f.n_out()) != (g.n_in(), g.n_out()):
        return False
    return (all(f.sparsity_in(i) == g.sparsity_in(i) for i in range(f.n_in()))
            and all(f.sparsity_out(i) == g.sparsity_out(i) for i in range(f.n_out())))
