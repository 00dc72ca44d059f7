"""Consumer 2, the optimizer (DMOC): a problem stated by the user (`statement`), transcribed
into a nonlinear program whose every step is the step residual (`nlp`), and solved by IPOPT
(`solver`); for a rigid body on SO(3), the same three parts on the group step residual
(`statement.group_problem`, `nlp.group_transcription`, `solver.group_solving`). The judged solve `dmoc.optimize` and the MPC are drivers (`dmoc.drivers`)."""

from .solver.guess import initial_guess
from .solver.ipopt import DEFAULT_IPOPT_OPTIONS
from .solver.optimization_result import OptimizationResult
from .solver.solving import solve
from .solver.verdict_record import Verdict
from .solver.waypoints import from_waypoints
from .statement.group_problem import GroupOptimalControlProblem
from .statement.problem import OptimalControlProblem

__all__ = ["OptimalControlProblem", "GroupOptimalControlProblem", "solve", "OptimizationResult", "Verdict",
           "DEFAULT_IPOPT_OPTIONS", "initial_guess", "from_waypoints"]
