"""Exceptions raised by dmoc.

`SolverError` is raised when a consumer of the step residual (the simulator's Newton
iteration or the optimizer's IPOPT run) fails; it keeps what was computed in `.result`.
"""


class DmocError(Exception):
    """Base class of every error dmoc raises on its own account."""


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
