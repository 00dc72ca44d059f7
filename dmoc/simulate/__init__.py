"""Consumer 1, the simulator: `simulate` solves the step residual for one step after another
(the Newton stepper, `stepper`), compiled to C once a run is long enough (`compiled`)."""

from .simulation import SimulationResult, simulate

__all__ = ["simulate", "SimulationResult"]
