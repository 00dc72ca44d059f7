"""Which linear solvers this IPOPT build has (consumer 2, solver half), so that
``options={"linear_solver": ...}`` is checked like an argument before a solver is built:
a name IPOPT does not know, or a solver this build lacks (the HSL solvers need the HSL
library where IPOPT finds it, Pardiso its own), is refused naming the option and the
solvers there are. They are tried once per process, on a one-variable NLP, in a child
process.
"""

import functools
import subprocess
import sys

from ...errors import InputError

# the values IPOPT's option linear_solver takes (IPOPT 3.14's documentation)
# (tried in this order: those that can crash the trying process last)
KNOWN = ("mumps", "spral", "ma27", "ma57", "ma77", "ma86", "ma97", "wsmp", "pardisomkl",
         "pardiso", "custom")


def check_linear_solver(options):
    """Refuse (InputError) ``options["linear_solver"]`` unless it is one of KNOWN that this
    IPOPT has (`available`; "custom", a solver linked in through IPOPT's C++ interface, is
    never there for CasADi). When the probe found none (it crashed or hung before the
    first), nothing is refused for availability: IPOPT reports an unavailable solver itself."""
    if "linear_solver" not in options:
        return
    value = options["linear_solver"]
    name = value.lower() if isinstance(value, str) else value
    if name not in KNOWN:
        raise InputError(f"`options['linear_solver']` must be one of IPOPT's linear solvers "
                         f"{', '.join(map(repr, KNOWN))}; got {value!r}.")
    have = available()
    if have and name not in have:      # none found: the probe itself failed, IPOPT decides
        raise InputError(f"`options['linear_solver']` = {value!r} is not available in this "
                         f"IPOPT build, which has {', '.join(map(repr, have))} (the HSL "
                         f"solvers ma27-ma97 need the HSL library installed where IPOPT finds "
                         f"it); leave `linear_solver` unset for {have[0]!r}.")


@functools.lru_cache(maxsize=1)
def available():
    """The names of KNOWN with which IPOPT solves a one-variable NLP, tried once per process
    in a child process (a failed try of one solver after another's can crash IPOPT: Pardiso
    after the HSL solvers), each name printed as it is found; a crash loses only the names
    after it, tried last (those that crash)."""
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE, *KNOWN[:-1]], capture_output=True,
                              text=True, check=False, timeout=300)
    except subprocess.TimeoutExpired as err:     # what was printed before it hung still holds
        done = err
    stdout = done.stdout or ""
    stdout = stdout.decode() if isinstance(stdout, bytes) else stdout
    found = [line[len("found "):] for line in stdout.splitlines() if line.startswith("found ")]
    return tuple(name for name in KNOWN if name in found)


_PROBE = """
import sys
import casadi as ca
x = ca.SX.sym("x")
for name in sys.argv[1:]:
    try:
        solver = ca.nlpsol("probe", "ipopt", {"x": x, "f": (x - 1) ** 2},
                           {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                            "ipopt.linear_solver": name})
        solver(x0=0)
        if solver.stats()["success"]:
            print("found " + name, flush=True)
    except RuntimeError:
        pass
"""
