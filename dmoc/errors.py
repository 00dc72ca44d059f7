"""Exceptions raised by dmoc (the taxonomy of docs/errors.md) and the vocabulary of the
outcomes a result reports (`Status`).

Every error dmoc raises on its own account is a `DmocError`. A bad argument is an
`InputError` (a wrong value: shape, range, NaN, an unknown choice) or an `InputTypeError`
(a wrong kind of object); they are also `ValueError` and `TypeError`, so code that catches
the built-in exceptions keeps working. A file that is not a dmoc trajectory is a
`TrajectoryFileError`; a file to read that does not exist a `MissingFileError` (also a
`FileNotFoundError`). `SolverError` is raised when a consumer of the step residual (the
simulator's Newton iteration or the optimizer's IPOPT run) fails; it keeps what was
computed in `.result`. A `CompiledCodeError` says why compiled code could not be built or
loaded safely (a cache folder others can write, a failed compile). `Interrupted` is the
KeyboardInterrupt of a run stopped by Ctrl-C (SIGINT), carrying what was computed up to
then in `.result`.
Warnings (the computation goes on) are `DmocWarning`s, a UserWarning: `OrderReductionWarning`
when a rule keeps a lower order on a degenerate Lagrangian, `ParasiticModeWarning` when its
step equations have a growing alternating mode. A spelling dmoc still takes but will drop
gives a `DmocDeprecationWarning`, a DeprecationWarning.
The ``status`` of a result is a `Status` member (a str: it equals its value) for an outcome
dmoc names; an optimization that dmoc does not judge otherwise keeps IPOPT's own return
status, a plain str such as ``"Solve_Succeeded"``.
"""

import enum


class DmocError(Exception):
    """Base class of every error dmoc raises on its own account."""


class InputError(DmocError, ValueError):
    """An argument has a wrong value: its message names the argument, what was expected and
    what was given, e.g. "`q0` must have shape (3,) for this system; got (2,)."."""


class InputTypeError(DmocError, TypeError):
    """An argument is the wrong kind of object (a string for a number, a symbolic
    expression for an array, a list for a Trajectory); the message names it."""


class TrajectoryFileError(InputError):
    """A file given to `Trajectory.load` is missing, truncated, empty or not written by
    `Trajectory.save`; the message names the file and says which."""


class MissingFileError(DmocError, FileNotFoundError):
    """There is no file at a path given to a load (`Trajectory.load`,
    `OptimizationResult.load`); the message names the path. It is a FileNotFoundError, the
    class code that opens files catches."""


class SolverError(DmocError):
    """A Newton or IPOPT solve failed.

    Parameters
    ----------
    message : str
        What failed, where (step, time, residual norm or IPOPT status), and how to look.
    result : object
        The partial result: a `SimulationResult` holding the trajectory up to the failing
        step, or an `OptimizationResult` holding the last iterate. ``result.success`` is
        False.
    """

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


class CompiledCodeError(DmocError, RuntimeError):
    """Compiled C code could not be built or loaded safely: no private cache folder (one
    that is not the user's, or that group or others can write), a compile that failed, a
    library whose signature is not the step's. The message names the folder or file and
    the way out; `simulate(jit=None)` turns it into one warning and CasADi's virtual
    machine."""
class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (SIGINT); raised by `simulate` and `optimize` with
    ``throw=True`` instead of a bare KeyboardInterrupt.

    It is a KeyboardInterrupt, not a `DmocError`: ``except Exception`` does not swallow a
    Ctrl-C, and a program that does not catch it stops as on any Ctrl-C.

    Parameters
    ----------
    message : str
        What was interrupted and how much was done.
    result : object
        The `SimulationResult` of the steps completed before the interrupt, or the
        `OptimizationResult` of IPOPT's last iterate; ``result.status`` is
        ``"interrupted"`` and ``result.success`` False.
    """

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


def failure(message, result):
    """The exception for a failed `result` (with `message`): `Interrupted` when a Ctrl-C
    stopped it (``result.status == "interrupted"``), else `SolverError`; both carry
    `result`. One rule for every driver, so a Ctrl-C is never reported as a failed
    solve."""
    error = Interrupted if result.status == Status.INTERRUPTED else SolverError
    return error(message, result)


class DmocWarning(UserWarning):
    """Base class of the warnings dmoc gives on its own account: the computation goes on,
    but a result may not have the property the user expects (docs/errors.md, "Warnings")."""


class OrderReductionWarning(DmocWarning):
    """`discretize` chose a rule whose order drops on this system: a stage rule (lobatto3,
    lobatto4) on a degenerate Lagrangian. The message names the rule and both orders;
    ``Discretization.order`` holds the order kept (docs/degenerate.md)."""


class ParasiticModeWarning(DmocWarning):
    """The step equations of a rule on a degenerate Lagrangian have an alternating
    (parasitic) mode that grows along the motion (the trapezoid on a nonlinear flow): once
    excited it swamps the solution over long runs. The message names the rule, the growth
    measured and the rule to use instead (docs/degenerate.md, "The alternating mode")."""


class DmocDeprecationWarning(DeprecationWarning):
    """A spelling of dmoc's own that still works but will go (an entry of `options` that is
    a keyword of `optimize`): the message names what to write instead (docs/errors.md,
    "Warnings"). A class of its own, so that a test suite can make dmoc's deprecations
    errors without those of the libraries below it."""


class Status(str, enum.Enum):
    """The outcomes dmoc names in a result's ``status``, one vocabulary for the simulator, the
    optimizer's verdict and accuracy loop, and the batches.

    Each member is a str equal to its value (``Status.PASSED == "passed"``), so code that
    compares with the strings, `json.dumps` and the files written before the enumeration
    keep working; ``status.message`` says what the status means (one table, `MESSAGES`).
    IPOPT's own return statuses (``"Solve_Succeeded"``, ``"Maximum_Iterations_Exceeded"``,
    ...) are IPOPT's and stay plain strings; `status_of` reads either.
    """

    CONVERGED = "converged"
    NEWTON_FAILED = "newton_failed"
    NON_FINITE = "non_finite"
    INTERRUPTED = "interrupted"
    PASSED = "passed"
    NOT_REPLAYABLE = "not_replayable"
    GOAL_MISSED = "goal_missed"
    PATH_VIOLATED = "path_violated"
    UNDER_RESOLVED = "under_resolved"
    ACCURACY_NOT_REACHED = "accuracy_not_reached"
    TIMEOUT = "timeout"
    WORKER_LOST = "worker_lost"
    SCHEDULER_LOST = "scheduler_lost"
    EXCEPTION = "exception"
    UNDESERIALIZABLE = "undeserializable"

    __str__ = str.__str__
    __format__ = str.__format__

    @property
    def message(self):
        """What the status says about the result (str)."""
        return MESSAGES[self]


MESSAGES = {
    Status.CONVERGED: "every step's Newton iteration converged",
    Status.NEWTON_FAILED: "a step's Newton iteration did not converge",
    Status.NON_FINITE: "a step produced NaN or Inf",
    Status.INTERRUPTED: "stopped by Ctrl-C (SIGINT)",
    Status.PASSED: "the optimum passed the verdict's checks",
    Status.NOT_REPLAYABLE: "simulating the optimum's controls from its initial state departs from it",
    Status.GOAL_MISSED: "the optimum's last knot is not at the goal (a problem on SO(3))",
    Status.PATH_VIOLATED: "a path constraint fails at a knot",
    Status.UNDER_RESOLVED: "a step velocity changes by a large part of its peak within one step",
    Status.ACCURACY_NOT_REACHED: "the largest number of steps allowed did not reach the accuracy asked for",
    Status.TIMEOUT: "the item or the batch ran past its time limit",
    Status.WORKER_LOST: "the worker running the item was lost, or no worker came",
    Status.SCHEDULER_LOST: "the client lost the batch's scheduler before the item's result arrived",
    Status.EXCEPTION: "the item's solve raised an exception",
    Status.UNDESERIALIZABLE: "the item's arguments could not be unpickled on the worker",
}


def status_of(text):
    """The `Status` of value `text`, or `text` itself (a str) when it names none: IPOPT's
    return statuses, or a status a newer dmoc wrote.

    Parameters
    ----------
    text : str

    Returns
    -------
    Status or str
    """
    try:
        return Status(text)
    except ValueError:
        return str(text)
