"""Consumer 1, the simulator: `simulate` (module `time_stepping`) solves the step residual
for one step after another (the Newton stepper, `stepper`, its unrolled iterations
`fast_path`, its Newton update `schur_complement` and the blocks of steps it evaluates at
once, `step_blocks`), compiled to
C once a run is long enough (`dmoc._util.compiled`); `lockstep` runs many at once."""

from .time_stepping import SimulationResult, simulate

__all__ = ["simulate", "SimulationResult"]
