"""What every run of the command line shares (``dmoc simulate``, ``dmoc optimize``, of a
system on R^n or of a rigid body on SO(3)): progress on stderr, the library's errors named
by the option that fed them, refusal of options a problem states itself, the files' name,
the printed summary with its exit code, and a run's files written together.
"""

import contextlib
import re
import sys

from ..errors import Status
from .._util.files import staged_run
from . import output
from .arguments import UsageError


def log(message):
    """Progress on stderr, so stdout keeps only the results."""
    print(f"dmoc: {message}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def options_named(mapping):
    """Turn a ValueError/TypeError of the library into a UsageError naming the CLI option
    that fed the argument the library names (its message quotes it in backticks)."""
    try:
        yield
    except (ValueError, TypeError) as err:
        message = str(err).splitlines()[0].rstrip(".")
        quoted = re.search(r"`([^`]+)`", message)
        name = quoted.group(1) if quoted else None
        raise UsageError(mapping.get(name, "SYSTEM"), message) from None


def refuse_stated(args, options):
    """A problem from a file states its discretization, final time and bounds: the
    `options` that would change them are refused, naming the way to change them."""
    for option in options:
        if getattr(args, option[2:].replace("-", "_")) is not None:
            raise UsageError(option, f"is stated by the problem that {args.system} returns; "
                             f"change it there (its factory's parameters are --param NAME=VALUE)")


def run_name(args):
    """The name of a run's files: the factory's, or the built-in system's."""
    return re.sub(r"\W+", "_", args.system.rpartition(":")[2] or args.system)


def report(summary, success, status, message, files):
    """Print the `summary` and the `files` written, log a failure or a Ctrl-C; return the
    exit code: 0 on success, 1 when the solver failed, 130 when a Ctrl-C stopped it."""
    width = max(map(len, summary))
    for key, value in summary.items():
        shown = f"{value:.6g}" if isinstance(value, float) else value
        print(f"{key:{width}s}  {shown}")
    for path in files:
        print(f"wrote {path}")
    if status == Status.INTERRUPTED:
        done = "wrote what was computed, without plots" if files else "nothing written (no --out)"
        log(f"{message.partition(';')[0].rstrip('.')}; {done}")
        return 130
    if not success:
        log(f"solver failed ({status}): {message}")
    return 0 if success else 1


def staged_files(out, prefix, write):
    """The paths in `out` of the files `write(stage)` writes into a staging folder and
    returns, all of a run's files replacing an earlier run's set together (`staged_run`);
    [] without `out`. A failed write changes nothing there (UsageError naming --out)."""
    if out is None:
        return []
    try:
        with staged_run(out, prefix, output.run_files(prefix)) as stage:
            written = write(stage)
    except OSError as err:  # disk full, file-size limit, folder removed
        raise UsageError("--out", f"writing into {str(out)!r} failed: {err.strerror or err}; "
                         f"nothing there was changed (an earlier run's files are as they "
                         f"were, none of this run's was written)") from None
    return [out / path.name for path in written]
