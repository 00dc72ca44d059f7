"""The principle stage's guard for degenerate Lagrangians: whether a rule's step
equations (37) can be solved for one step. A coordinate without kinetic energy (an LC
circuit's capacitor charges) enters its "left" row (37) only through the values L_d samples;
a rule that samples it only at the step ends (the trapezoid) leaves q_{k+1} out of that row,
and the step equations cannot determine q_{k+1}. `step_residual` refuses such a rule, so
`simulate`, `OptimalControlProblem` and every other user of the residual reject it alike
(docs/degenerate.md).
"""

import casadi as ca

from .._util.cache import BoundedCache
from ..errors import InputError

_UNDETERMINED = BoundedCache(32, "one_step_maps")


def check_one_step_map(disc, plus_residual):
    """Raise ValueError unless the step equations of `disc` determine q_{k+1}.

    Parameters
    ----------
    disc : Discretization
    plus_residual : callable
        Returns the (+) StepResidual of `disc`; called only when the answer for this
        system and rule is not known yet.

    Raises
    ------
    ValueError
        Naming the rule, the coordinates (``system.names``) whose rows leave q_{k+1}
        undetermined, and the rule to use instead.

    Notes
    -----
    The test is structural: see `undetermined_coordinates`.
    """
    found = _UNDETERMINED.get(disc.key, lambda: undetermined_coordinates(plus_residual()))
    if not found:
        return
    names = tuple(disc.system.names[i] for i in found)
    hint = ("Use rule='midpoint', which samples every coordinate at the step midpoint."
            if disc.rule.name != "midpoint" else
            "Every coordinate must enter L, A(q) or f so that its row involves q_{k+1}.")
    raise InputError(
        f"`rule` {disc.rule.name!r} gives no one-step map for this system: the coordinates "
        f"{names} have no kinetic energy coupling q_k to q_{{k+1}} under this rule, so their "
        f"step equations (37) do not involve q_{{k+1}} and the step cannot be solved for it. "
        + hint)


def undetermined_coordinates(R):
    """Coordinates whose step equations leave q_{k+1} structurally undetermined.

    Parameters
    ----------
    R : StepResidual
        The (+) residual of the discretization.

    Returns
    -------
    tuple of int
        Indices into q, sorted; empty when the step equations have full structural rank.

    Notes
    -----
    The step equations are the rows of the (+) residual but "right": left (n), stage
    (n_stages) and constraint (m), in the unknowns (q_{k+1}, lam_k, s), as the simulator
    solves them (the (-) form has the same pattern, its multiplier at q_k entering through
    A(q_k)^T as well). On the bipartite graph of the Jacobian's sparsity, the rows reachable
    by alternating paths from the rows a maximum matching leaves unmatched form the
    over-determined block of the Dulmage-Mendelsohn decomposition: they involve fewer
    unknowns than there are of them. The coordinates of its left and stage rows are returned.

    The sparsity is the residual Function's own dependency pattern of those rows on those
    inputs (``Function.jac_sparsity``, propagated through its operations) rather than that
    of a symbolic Jacobian: the structure without differentiating the step (0.3-0.9 ms a
    rule on the rolling disk, paid by every problem's first build).
    """
    F = R.function
    pattern = ca.horzcat(*[F.jac_sparsity(0, F.index_in(k)) for k in ("q1", "lam", "s")])
    rows = [i for k in ("left", "stage", "constraint") for i in range(R.rows[k].start, R.rows[k].stop)]
    adjacency = _adjacency(pattern)
    rows_of = [adjacency[i] for i in rows]
    coordinate_rows = R.n + R.n_stages
    return tuple(sorted({i % R.n for i in _overdetermined(rows_of) if i < coordinate_rows}))


def _adjacency(sparsity):
    """For each row of a sparsity pattern, the columns of its structural nonzeros."""
    rows_of = [[] for _ in range(sparsity.size1())]
    for i, j in zip(*sparsity.get_triplet()):
        rows_of[i].append(j)
    return rows_of


def _overdetermined(rows_of):
    """Rows reachable by alternating paths from the rows left unmatched by a maximum
    matching (Kuhn's augmenting paths); empty if every row is matched."""
    match = {}                                        # column -> row

    def augment(i, seen):
        for j in rows_of[i]:
            if j not in seen:
                seen.add(j)
                if j not in match or augment(match[j], seen):
                    match[j] = i
                    return True
        return False

    unmatched = [i for i in range(len(rows_of)) if not augment(i, set())]
    reached, stack = set(unmatched), list(unmatched)
    while stack:
        for j in rows_of[stack.pop()]:
            if j in match and match[j] not in reached:
                reached.add(match[j])
                stack.append(match[j])
    return reached
