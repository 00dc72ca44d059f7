"""The discretization stage's entry point: `discretize` chooses the discretization a system
takes (discrete Lagrangian or discrete Hamiltonians) and builds it."""

from ..errors import InputTypeError
from ..mechanics.system import HamiltonianSystem, MechanicalSystem
from .degenerate import warn_order_reduction
from .discretization import Discretization
from .group_discretization import GROUP_SYSTEMS, GroupDiscretization
from .hamiltonian import HamiltonianDiscretization


def discretize(system, h, rule="midpoint"):
    """Discrete Lagrangian (or discrete Hamiltonians), constraints (28) and forces of
    `system` on steps of size `h`.

    Parameters
    ----------
    system : MechanicalSystem or HamiltonianSystem or RigidBody or FloatingBaseRobot
    h : float
        Step size, > 0.
    rule : str or QuadratureRule or HamiltonianRule
        For a MechanicalSystem a name in `dmoc.discrete.RULES` (``"midpoint"``, the
        default, ``"trapezoid"``, ``"lobatto3"``, ``"lobatto4"``) or a rule instance; for a
        HamiltonianSystem a name in `dmoc.discrete.HAMILTONIAN_RULES` (``"midpoint"``,
        ``"symplectic-euler"``) or a HamiltonianRule; for a RigidBody or a
        FloatingBaseRobot ``"midpoint"``, the Lie group variational integrator on SO(3)
        (`GroupDiscretization`).

    Returns
    -------
    Discretization or HamiltonianDiscretization or GroupDiscretization

    Raises
    ------
    ValueError
        An unknown rule or a step that is not positive.
    TypeError
        `system` of another type.

    Warns
    -----
    OrderReductionWarning
        A stage rule on a degenerate Lagrangian (d^2L/dv^2 singular): lobatto3 keeps order
        2, lobatto4 order 4, which ``Discretization.order`` reports
        (`dmoc.discrete.degenerate`). Whether the step equations determine q_{k+1} and
        whether their alternating mode grows is tested where the step residual is built
        (`dmoc.step_residual`).

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
    if isinstance(system, GROUP_SYSTEMS):
        return GroupDiscretization(system, h, rule)
    if not isinstance(system, MechanicalSystem):
        raise InputTypeError(f"`system` must be a MechanicalSystem, a HamiltonianSystem, a "
                             f"RigidBody or a FloatingBaseRobot; got {type(system).__name__}.")
    disc = Discretization(system, h, rule)
    warn_order_reduction(disc)
    return disc
