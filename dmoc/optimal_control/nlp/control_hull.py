"""Control bounds that hold between a rule's control nodes (consumer 2 of the step
residual): a rule with d + 1 >= 3 control nodes interpolates each step's control values by
a polynomial of degree d (`Rule.control_at`, what `Trajectory.control` reads), which can
leave the box its node values lie in (lobatto3's quadratic through 0.8, 0.8 and 0.55 peaks
above 0.8). Written in the Bernstein basis on [0, 1], p(c) = sum_i b_i C(d, i) c^i
(1 - c)^(d - i), the polynomial lies in the convex hull of its coefficients b_i; b_0 and
b_d are its values at c = 0 and 1 (nodes of every Lobatto rule), so bounding b_1 ...
b_{d-1}, linear combinations of the node values, bounds the control everywhere on the
step. A control held at a bound over a step (all nodes at it) has every b_i there, so no
bang-bang arc is excluded; a sufficient condition, it may exclude a curve that touches a
bound between nodes (docs/stages/optimize.md, "Control bounds between the nodes").

Rows (g block ``control_hull`` of `Transcription.g_layout`): for each step, the interior
Bernstein coefficients b_1 ... b_{d-1} of each control with a finite bound, coefficient by
coefficient, within that control's bounds.
"""

import math

import casadi as ca
import numpy as np


def hull_matrix(nodes):
    """T, shape (d - 1, d + 1): the interior Bernstein coefficients b_1 ... b_{d-1} of the
    degree-d polynomial through the values at `nodes` (d + 1 distinct points of [0, 1]),
    ``b = T @ values``; shape (0, len(nodes)) when d < 2 (the node values bound it)."""
    c = np.asarray(nodes, dtype=float)
    d = c.size - 1
    if d < 2:
        return np.zeros((0, c.size))
    basis = np.array([[math.comb(d, i) * cj ** i * (1 - cj) ** (d - i) for i in range(d + 1)] for cj in c])
    return np.linalg.solve(basis, np.eye(d + 1))[1:d]


def hulled_controls(control_bounds, nodes):
    """The indices of the controls whose interpolant needs hull rows: those with a finite
    bound, when the rule has 3 or more control nodes; a list of int."""
    if len(nodes) < 3:
        return []
    lower, upper = control_bounds
    return [i for i in range(len(lower)) if np.isfinite(lower[i]) or np.isfinite(upper[i])]


def hull_terms(step, G):
    """The term of block ``control_hull`` of the problem of `step` (`terms._StepSlots`), G
    the row indices by block: for each step ``T @ values`` of each control of
    `hulled_controls`, coefficient by coefficient (the control index fastest), from the
    step's control values (node by node); none for an empty block."""
    if not G["control_hull"].size:
        return []
    problem = step.problem
    nodes, n_u = problem.disc.rule.control_nodes, problem.disc.system.n_u
    T, hulled = hull_matrix(nodes), hulled_controls(problem.control_bounds, nodes)

    def rows(s):
        u = s["u"]
        return 0, ca.vertcat(*[sum(T[i, j] * u[j * n_u + k] for j in range(T.shape[1]))
                               for i in range(T.shape[0]) for k in hulled])
    slots = {name: slot for name, slot in step.at(0, step.N).items() if name == "u"}
    return [step.term("control_hull_" + "_".join(map(str, hulled)), slots, rows, G["control_hull"])]


def hull_bounds(control_bounds, nodes):
    """(lower, upper), each of shape (rows per step,): the bounds of one step's
    ``control_hull`` rows, each coefficient's those of its control."""
    hulled, count = hulled_controls(control_bounds, nodes), hull_matrix(nodes).shape[0]
    return tuple(np.tile(np.asarray(side, dtype=float)[hulled], count) for side in control_bounds)
