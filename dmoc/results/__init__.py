"""The results stage: diagnostics of a computed Trajectory (energy, constraint violation,
residual norms, replay), the verdict on an optimum (`verdict`), the accuracy of an optimum
(`error_estimate`: its error estimate; `accuracy`: grids refined to a target), the public
`optimize` that joins them (`optimum`), its plots and its animation."""

from . import accuracy, animation, diagnostics, error_estimate, plotting, verdict
from .optimum import optimize

__all__ = ["diagnostics", "plotting", "animation", "verdict", "error_estimate", "accuracy", "optimize"]
