"""Degenerate Lagrangians at the discretization stage: whether d^2L/dv^2 is singular, the
order a rule keeps on such an L (`Discretization.order`), and the warning `discretize`
gives when a stage rule loses order there (docs/degenerate.md, "Order of the stage rules").
The representative states sampled here also serve the principle stage's test of the
alternating mode (`dmoc.principle.parasitic`).
"""

import warnings

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from ..errors import OrderReductionWarning

SAMPLE_SEED = 20231
SAMPLE_COUNT = 2
# the rank's tolerance on the equilibrated d^2L/dv^2 (every row's largest entry about 1):
# sqrt(eps), far from both a singular H (a singular value at round-off, eps times the
# growth of the errors along the expression graph) and an H singular only because of the
# units of its coordinates, which equilibration removes
RANK_TOLERANCE = np.sqrt(np.finfo(float).eps)
EQUILIBRATION_SWEEPS = 64

_DEGENERATE = BoundedCache(32, "degenerate_lagrangians")


def sample_states(system, count=SAMPLE_COUNT):
    """Representative states of `system`: `count` pairs (q, v), each of shape (n,), drawn
    uniformly from [-1, 1]^n with a fixed seed (so every run tests the same states)."""
    rng = np.random.default_rng(SAMPLE_SEED)
    return [(rng.uniform(-1.0, 1.0, system.n), rng.uniform(-1.0, 1.0, system.n))
            for _ in range(count)]


def is_degenerate(system):
    """Whether the Lagrangian of `system` is degenerate on the constraint distribution:
    N^T (d^2L/dv^2) N, N (n, n - m) a basis of ker A(q), has rank below n - m at every
    state of `sample_states` where it is finite (a Lagrangian singular on a thin set only,
    as L = v^4, counts as regular, and so does one not finite at any of them; a coordinate
    without inertia that the constraints tie to others, as a massless wheel's angle, does
    not make L degenerate). A HamiltonianSystem never is.

    Notes
    -----
    Singularity does not depend on the units of the coordinates: changing them scales
    v -> D v (D diagonal, positive) and the Hessian H -> D H D, which is singular exactly
    when H is. The test is made as invariant: the rank is taken of H equilibrated
    (`_equilibrated`: every nonzero row's largest entry in [1/2, 2]), at the tolerance
    RANK_TOLERANCE.
    A relative tolerance on H itself is not: the mass matrix M(q) of a regular robot is
    positive definite, but a light, thin link makes its condition number 1e12 (its
    inertia about its joint axis against the base's), and at a tolerance of 1e-10 the robot
    was called degenerate; equilibrated, that M has condition number about 100 (48 and
    106 at two states of a 6-joint chain whose tip has cond M 9.2e11), while the
    degenerate Lagrangians of `dmoc.systems` (the LC circuit, point vortices) keep a
    singular value at round-off, 2e-17 of the largest.
    """
    if not hasattr(system, "lagrangian"):
        return False
    return _DEGENERATE.get(system.key, lambda: _rank_deficient(system))


def _rank_deficient(system):
    q, v = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n)
    hessian = ca.Function("d2L_dv2", [q, v], [ca.hessian(system.lagrangian(q, v), v)[0],
                                               system.constraint_matrix(q)])
    deficient = []
    for q0, v0 in sample_states(system):
        H, A = (np.array(a) for a in hessian(q0, v0))
        if np.all(np.isfinite(H)) and np.all(np.isfinite(A)):
            N = _kernel(A, system.n)
            H = _equilibrated(N.T @ H @ N)
            deficient.append(np.linalg.matrix_rank(H, tol=RANK_TOLERANCE) < N.shape[1])
    return bool(deficient) and all(deficient)


def _equilibrated(H):
    """D H D for the symmetric H (k, k), D = diag(d) > 0 chosen by Ruiz's iteration
    d_i <- d_i / sqrt(max_j |(D H D)_ij|) (D. Ruiz, A scaling algorithm to equilibrate both
    rows and columns norms in matrices, RAL-TR-2001-034) until every nonzero row's largest
    entry lies in [1/2, 2] (at most EQUILIBRATION_SWEEPS sweeps; each halves the logarithm
    of a row's distance from 1). Zero rows stay zero. D H D is singular exactly when H is."""
    d = np.ones(len(H))
    for _ in range(EQUILIBRATION_SWEEPS):
        row = np.abs(d[:, None] * H * d[None, :]).max(axis=1, initial=0.0)
        row[row == 0.0] = 1.0
        if np.all((row >= 0.5) & (row <= 2.0)):
            break
        d /= np.sqrt(row)
    return d[:, None] * H * d[None, :]


def _kernel(A, n):
    """An orthonormal basis of ker A (n, n - rank A), from the SVD of A (m, n)."""
    if not A.size:
        return np.eye(n)
    _, sigma, Vt = np.linalg.svd(A)
    rank = int(np.sum(sigma > 1e-12 * max(1.0, sigma.max())))
    return Vt[rank:].T


def declared_order(system, rule):
    """The global order of `rule` on `system`: ``rule.degenerate_order`` for a degenerate
    Lagrangian when the rule declares one, else ``rule.order``."""
    reduced = getattr(rule, "degenerate_order", None)
    if reduced is not None and reduced < rule.order and is_degenerate(system):
        return reduced
    return rule.order


def warn_order_reduction(disc):
    """Warn (OrderReductionWarning) when `disc` keeps a lower order than its rule's,
    naming the rule, both orders and what to do instead."""
    if disc.order < disc.rule.order:
        warnings.warn(OrderReductionWarning(
            f"`rule` {disc.rule.name!r} has order {disc.order}, not {disc.rule.order}, on this "
            f"degenerate Lagrangian (d^2L/dv^2 singular): the rule's Lobatto IIIA-IIIB pairing "
            f"assumes a regular Legendre transform, and the error falls as h^{disc.order}, as "
            f"`Discretization.order` says. On such Lagrangians 'midpoint' keeps order 2 at less "
            f"cost than 'lobatto3', and 'lobatto4' keeps order 4 (docs/degenerate.md, 'Order of "
            f"the stage rules')."), stacklevel=3)
