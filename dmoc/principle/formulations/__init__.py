"""Formulations of the implicit discrete equations as values: the Lagrangian (+) form (37)
from the discrete Lagrange-d'Alembert-Pontryagin sum (46) and (-) form (41) from (47), and
the Hamiltonian (+) form (39) from the discrete Hamilton-d'Alembert sum (48) and (-) form
(43) from (49). Each owns every convention that depends on it: the sum it differentiates,
the node whose variations are restricted to Delta_Q (the d'Alembert multiplier sits there),
the impulses at the start and the end, the momentum boundary rows of the optimizer, how a
solved step fills a Trajectory, which end variable a step gives explicitly, and its Dirac
differential (36)/(38)/(40)/(42). The principle, the stepper, `simulate`, the optimizer,
the diagnostics and `dmoc.dirac` ask it and never compare variant strings
(docs/theory.md, "Conventions").
"""

from ..._util import checks
from .base import Formulation, MinusForm, PlusForm
from .hamiltonian import HamiltonianMinus, HamiltonianPlus
from .lagrangian import LagrangianMinus, LagrangianPlus, Window
from ...errors import InputError

FORMULATIONS = {f.name: f for f in (LagrangianPlus(), LagrangianMinus())}
HAMILTONIAN_FORMULATIONS = {f.name: f for f in (HamiltonianPlus(), HamiltonianMinus())}
FAMILIES = {"lagrangian": FORMULATIONS, "hamiltonian": HAMILTONIAN_FORMULATIONS}


def as_formulation(variant, disc=None):
    """The Formulation of `variant` ("+" or "-", or an instance) for the discretization
    `disc`: of its family (``disc.family``, Lagrangian or Hamiltonian), Lagrangian when
    `disc` is None.

    >>> as_formulation("-").multiplier_node
    1
    """
    family = FAMILIES["lagrangian" if disc is None else disc.family]
    if isinstance(variant, Formulation):
        if variant not in family.values():
            raise InputError(f"`variant` {variant!r} does not belong to this discretization; "
                             f"use one of {tuple(family)} or {list(family.values())}.")
        return variant
    return family[checks.choice("variant", variant, tuple(family))]


__all__ = ["Formulation", "PlusForm", "MinusForm", "Window", "LagrangianPlus", "LagrangianMinus",
           "HamiltonianPlus", "HamiltonianMinus", "FORMULATIONS", "HAMILTONIAN_FORMULATIONS",
           "as_formulation"]
