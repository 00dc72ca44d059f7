"""The results stage: diagnostics of a computed Trajectory (energy, constraint violation,
residual norms, replay), its plots and its animation, and the accuracy of an optimum (its
error estimate, grids refined to a target)."""

from . import accuracy, animation, diagnostics, plotting

__all__ = ["diagnostics", "plotting", "animation", "accuracy"]
