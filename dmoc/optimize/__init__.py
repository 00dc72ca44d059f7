"""Consumer 2, the optimizer (DMOC): the user's statement (`problem`, with its boundary rows
and parameters, its final time `final_time` and momentum treatment `momenta` chosen as
values, read-only by `read_only`), its NLP (`transcription`: the terms of `terms` in
`separable`, assembled by the index arithmetic of `gather_scatter`, scaled by `scaling`)
and its solution (`solve`: IPOPT through `ipopt`, its journal `linear_solver`, the start
point `guess` or `waypoints`; its outcome an `optimization_result` with the record of a
`verdict`), the receding-horizon controller `mpc`, the step residual imposed at every step;
`problems` holds the built-in examples. `dmoc.optimize`, the judged solve, is `solve`
followed by the checks of `dmoc.results.verdict`."""

from . import problems
from .guess import initial_guess
from .ipopt import DEFAULT_IPOPT_OPTIONS
from .mpc import MPC, MPCStep
from .problem import OptimalControlProblem
from .optimization_result import OptimizationResult
from .solve import solve
from .verdict import Verdict
from .waypoints import from_waypoints

__all__ = ["OptimalControlProblem", "solve", "OptimizationResult", "Verdict",
           "DEFAULT_IPOPT_OPTIONS", "initial_guess", "from_waypoints", "MPC", "MPCStep",
           "problems"]
