"""CasADi Functions compiled to C once and kept on disk, keyed by what they compute: the
simulator's compiled step horizons (`dmoc.simulate.stepper`). A library is named by the
SHA-256 of the serialized Functions, the CasADi version and the compiler command, so every
process, later ones included, loads the same code with `casadi.external` instead of compiling
again; where no C compiler exists, `compiler()` is None and callers keep CasADi's virtual
machine, which computes the same thing (`Library`).

The cache directory is ``$DMOC_CACHE_DIR``, else ``$XDG_CACHE_HOME/dmoc`` (default
``~/.cache/dmoc``), else a per-user directory under the system's temporary directory when
that is not writable. The compiler is ``$CC`` (default ``cc``, then ``gcc``); set ``CC``
to an empty string to disable compilation.
"""

import getpass
import hashlib
import os
import shutil
import subprocess
import tempfile

import casadi as ca

FLAGS = ("-O2", "-fPIC", "-shared")


def compiler():
    """Path of the C compiler, or None when there is none (or ``CC`` is set empty)."""
    name = os.environ.get("CC")
    candidates = (name,) if name is not None else ("cc", "gcc")
    for candidate in candidates:
        path = shutil.which(candidate) if candidate else None
        if path:
            return path
    return None


def cache_dir():
    """The directory holding compiled libraries, created if needed (see the module notes)."""
    configured = os.environ.get("DMOC_CACHE_DIR")
    if configured:
        candidates = [configured]
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        candidates = [os.path.join(base, "dmoc"),
                      os.path.join(tempfile.gettempdir(), f"dmoc-{getpass.getuser()}")]
    for path in candidates:
        try:
            os.makedirs(path, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            return path
    raise OSError(f"no writable cache directory for compiled code among {candidates}; "
                  "set DMOC_CACHE_DIR.")


class Library:
    """The C library of CasADi `functions` (distinct names) at
    ``<cache dir>/<stem>-<key>.so``, its key the SHA-256 of what it computes and how it is
    compiled (`path` is None without a C compiler)."""

    def __init__(self, functions, stem):
        self.functions, self.cc = list(functions), compiler()
        self.path = None
        if self.cc is not None:
            digest = hashlib.sha256(f"casadi {ca.__version__}; {self.cc} {' '.join(FLAGS)}".encode())
            for function in self.functions:
                digest.update(function.serialize().encode())
            self.path = os.path.join(cache_dir(), f"{stem}-{digest.hexdigest()[:32]}.so")

    def cached(self):
        """True when the library is on disk already."""
        return self.path is not None and os.path.exists(self.path)

    def load(self):
        """{name: Function} loaded with `casadi.external`, compiling the library first if it
        is not cached. Code is generated and compiled in a fresh temporary directory in the
        cache directory and moved into place atomically, so concurrent processes never
        load a half-written library (the working directory is never written to)."""
        if self.path is None:
            raise RuntimeError("no C compiler: nothing can be compiled (see dmoc.compiled).")
        if not self.cached():
            self._compile()
        return {f.name(): ca.external(f.name(), self.path) for f in self.functions}

    def _compile(self):
        with tempfile.TemporaryDirectory(dir=os.path.dirname(self.path)) as work:
            generator = ca.CodeGenerator("library.c", {"with_header": False})
            for function in self.functions:
                generator.add(function)
            source = generator.generate(work + os.sep)
            target = os.path.join(work, "library.so")
            done = subprocess.run([self.cc, *FLAGS, source, "-o", target, "-lm"],
                                  capture_output=True, text=True)
            if done.returncode:
                raise RuntimeError(f"compiling {source} with {self.cc} failed:\n{done.stderr}")
            os.replace(target, self.path)
