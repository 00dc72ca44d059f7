"""The discretization stage's entry point: `discretize` chooses the discretization a system
takes (discrete Lagrangian or discrete Hamiltonians) and builds it."""

from ..errors import InputTypeError
from ..mechanics.system import HamiltonianSystem, MechanicalSystem
from .discretization import Discretization
from .hamiltonian import HamiltonianDiscretization


def discretize(system, h, rule="midpoint"):
    """Discrete Lagrangian (or discrete Hamiltonians), constraints (28) and forces of
    `system` on steps of size `h`.

    Parameters
    ----------
    system : MechanicalSystem or HamiltonianSystem
    h : float
        Step size, > 0.
    rule : str or QuadratureRule or HamiltonianRule
        For a MechanicalSystem a name in `dmoc.discrete.RULES` (``"midpoint"``, the
        default, ``"trapezoid"``, ``"lobatto3"``, ``"lobatto4"``) or a rule instance; for a
        HamiltonianSystem a name in `dmoc.discrete.HAMILTONIAN_RULES` (``"midpoint"``,
        ``"symplectic-euler"``) or a HamiltonianRule.

    Returns
    -------
    Discretization or HamiltonianDiscretization

    Raises
    ------
    ValueError
        An unknown rule, a step that is not positive, or a rule that gives no one-step map
        for a degenerate Lagrangian (`dmoc.discrete.degenerate`).
    TypeError
        `system` of another type.

    Examples
    --------
    >>> import casadi as ca
    >>> from dmoc import MechanicalSystem, discretize
    >>> s = MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) - 0.5 * ca.dot(q, q), 1)
    >>> d = discretize(s, 0.1)
    >>> round(float(d.discrete_lagrangian(0.0, 0.2, [], 0.1)), 6)  # 0.1 * (2 - 0.005)
    0.1995
    """
    if isinstance(system, HamiltonianSystem):
        return HamiltonianDiscretization(system, h, rule)
    if not isinstance(system, MechanicalSystem):
        raise InputTypeError(f"`system` must be a MechanicalSystem or a HamiltonianSystem; got "
                        f"{type(system).__name__}.")
    return Discretization(system, h, rule)
