"""What IPOPT's linear solver did in a solve (consumer 2, solver half): the factorizations of
the KKT matrices, the increases of the pivot tolerance, the failed iterative refinements
and MUMPS's workspace reallocations, which CasADi's `stats` do not carry. IPOPT writes
them only to its detailed journal (print level 6); `dmoc.optimize` with
``options={"linear_solver_report": True}`` has the solver append that journal to a file of
its own and reads each solve's part back.
"""

import atexit
import os
import re
import tempfile

JOURNAL_LEVEL = 6           # IPOPT's J_DETAILED, where the linear solvers report
_PIVOT = re.compile(r"Increasing pivot tolerance for \w+ from (\S+) to (\S+)\.")
_TRIALS = re.compile(r"Number of trial factorizations performed: (\d+)")


def new_journal():
    """The path of a new temporary file for the journal of one solver (IPOPT's
    ``output_file``, written at ``file_print_level`` `JOURNAL_LEVEL`; IPOPT keeps it open
    and appends every solve of that solver), removed when this process ends."""
    handle, path = tempfile.mkstemp(prefix="dmoc-ipopt-", suffix=".txt")
    os.close(handle)
    atexit.register(_remove, path, os.getpid())
    return path


def journal_end(path):
    """The size of the journal at `path` in bytes (0 before its first solve): where the
    next solve's part starts."""
    return os.path.getsize(path) if os.path.exists(path) else 0


def linear_solver_report(path, start):
    """The report of the solve whose journal begins at byte `start` of `path`.

    Returns
    -------
    dict
        ``factorizations`` (of the KKT matrix for the search directions, retries for
        the inertia included), ``pivot_tolerance_increases`` (each a refactorization
        after the iterative refinement failed), ``pivot_tolerance`` (the last value it was
        raised to, or None), ``refinement_failures``, ``reallocations`` (factorizations
        MUMPS stopped for want of workspace, IPOPT doubling ``mumps_mem_percent`` and
        factorizing again).
    """
    with open(path, encoding="utf-8", errors="replace") as file:
        file.seek(start)
        text = file.read()
    increases = _PIVOT.findall(text)
    return {"factorizations": sum(int(k) for k in _TRIALS.findall(text)),
            "pivot_tolerance_increases": len(increases),
            "pivot_tolerance": float(increases[-1][1]) if increases else None,
            "refinement_failures": text.count("Iterative refinement failed"),
            "reallocations": text.count("requires more memory, reallocating")}


def remove_journal(path):
    """Remove the journal at `path` (of a solver that is dropped), if it is still there."""
    try:
        os.remove(path)
    except OSError:
        pass


def _remove(path, owner):
    """Remove `path` at the exit of the process that made it (not of a forked child)."""
    if os.getpid() == owner:
        remove_journal(path)
