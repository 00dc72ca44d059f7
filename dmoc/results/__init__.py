"""The results stage: diagnostics of a computed Trajectory (energy, constraint violation,
residual norms, replay), the verdict on an optimum (`verdict`, whose `optimize` is the
judged solve), its plots and its animation."""

from . import animation, diagnostics, plotting, verdict
from .verdict import optimize

__all__ = ["diagnostics", "plotting", "animation", "verdict", "optimize"]
