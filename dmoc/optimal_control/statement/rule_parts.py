"""What a DMOC problem's statement takes from its rule (consumer 2, its statement): the
formulation of the step rows (37)/(41), the step residual, the momentum treatment and the
checked path constraints (which the NLP evaluates at the rule's points), made once per
discretization, by `OptimalControlProblem` and again by its `with_rule`."""

from typing import NamedTuple

from ...principle.formulations import as_formulation
from ...principle.residual import step_residual
from ..nlp.momenta import momentum_treatment
from .parameters import path_function


class RuleParts(NamedTuple):
    """The parts of a problem made from its discretization.

    Attributes
    ----------
    formulation : Formulation
    residual : StepResidual
    momentum_treatment : CarriedMomenta or SubstitutedMomenta
    path : casadi.Function or None
        `parameters.path_function` of the user's path constraints, None without them.
    """

    formulation: object
    residual: object
    momentum_treatment: object
    path: object


def rule_parts(disc, variant, momenta, path_constraints, parameters):
    """The RuleParts of a problem on `disc` with the user's `variant`, `momenta` choice,
    `path_constraints` (a callable or None) and its ProblemParameters."""
    formulation = as_formulation(variant, disc)
    residual = step_residual(disc, formulation)
    path = None if path_constraints is None else path_function(path_constraints, disc.system, parameters)
    return RuleParts(formulation, residual, momentum_treatment(momenta, residual), path)
