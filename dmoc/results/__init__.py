"""The results stage: diagnostics of a computed Trajectory (energy, constraint violation,
residual norms, replay), its plots and its animation."""

from . import animation, diagnostics, plotting

__all__ = ["diagnostics", "plotting", "animation"]
