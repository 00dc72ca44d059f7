"""Consumer 1, the simulator: `simulate` solves the step residual for one step after another
(the Newton stepper, `stepper`, its Newton update `schur_complement` and the chunks of
steps it evaluates at once, `chunks`), compiled to C once a run is long enough
(`dmoc._util.compiled`)."""

from .simulation import SimulationResult, simulate

__all__ = ["simulate", "SimulationResult"]
