"""Consumer 2, the optimizer (DMOC): the user's statement (`problem`, with its boundary rows
and parameters), its NLP (`transcription`, `separable`, `scaling`) and its solution
(`solve`: IPOPT through `ipopt`, its journal `linear_solver`, the start point `guess`), the
step residual imposed at every step; `problems` holds the built-in examples."""

from . import problems
from .guess import initial_guess
from .ipopt import DEFAULT_IPOPT_OPTIONS
from .problem import OptimalControlProblem
from .solve import OptimizationResult, optimize

__all__ = ["OptimalControlProblem", "optimize", "OptimizationResult", "DEFAULT_IPOPT_OPTIONS",
           "initial_guess", "problems"]
