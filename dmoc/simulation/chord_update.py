"""The chord (simplified Newton) updates of a step with many unknowns and a dense Jacobian
(`dmoc.simulation.fast_path`), and when the fast path's updates count as converged. J =
dg/dy is evaluated and factorized once, at the warm start y_0, as J_0 = (I + L) U by
Gaussian elimination (`chord_factors`), and every update is J_0^{-1} g(y), a forward and a
back substitution, O(n^2) on top of the rows g, O(n) for a robot's link recursion.
Newton's method evaluates J, O(n^2), and solves with it, O(n^3), at every update; the
chord does both once a step, and its updates converge linearly at the rate
|J_0^{-1} (J(y*) - J_0)| = O(|y_0 - y*|) (the warm start is the previous step's solution):
FIRST_CHORD_UPDATES of them, then more, up to CHORD_ITERATIONS, only while the error they
leave exceeds CHORD_STOP_TOL (`more_updates`: the geometric tail `remaining_error`, or, once
an update is at the round-off floor, the tail at the rate observed before it). Keeping J_0
across steps (as stiff ODE codes do) does not pay for a robot's chain: J changes by O(h |v|
|M^{-1} dM/dq|) a step, large against J where cond M is large (benchmarks/robots.py,
`--kept-jacobian`).
"""

import casadi as ca

from .schur_complement import DENSE_MINOR

NEWTON_UPDATE_TOL = 1e-6  # Newton's last relative update in an accepted step (its error ~ its square)
CHORD_ITERATIONS = 8      # at most, from the previous step's solution: as few steps left unconverged as Newton's three updates
FIRST_CHORD_UPDATES = 2   # at least: the fewest whose sizes give the observed rate; more only while not converged
CHORD_UPDATE_TOL = 1e-12  # the error an accepted chord step leaves, relative (`remaining_error`)
CHORD_STOP_TOL = 1e-18    # the error left at which the updates stop: below round-off of |y| ~ h |v|, as after all 8
ROUND_OFF_UPDATE = 8 * 2.0 ** -52   # a relative update this small may be round-off (`more_updates`)
STALLED_RATE = 1 - 1e-6   # a rate this close to 1 is a stall: iterates cycling at round-off


def chord_suited(pattern, unknowns):
    """Whether the fast path takes chord updates for the step equations over `unknowns` (a
    Layout of dq, nu and ds): no multipliers and no stage values (the rows are the "left"
    rows of a two-point rule), more than DENSE_MINOR unknowns (where Newton's update goes
    through QR) and a dense Jacobian dg/dy, as a robot's. `pattern` () -> the Sparsity of
    dg/dy, called only when the rest holds."""
    if unknowns.numel("nu") or unknowns.numel("ds") or unknowns.size <= DENSE_MINOR:
        return False
    J = pattern()
    return J.nnz() == J.numel()


def chord_factors(J):
    """(L, U) of J = (I + L) U by Gaussian elimination without pivoting (Golub and Van Loan,
    Matrix Computations, 4th ed., Alg. 3.2.1), dense SX of shape (n, n): L strictly lower
    triangular (the multipliers), U upper triangular with its diagonal's reciprocals on the
    diagonal. 2/3 n^3 operations where CasADi's QR (Gram-Schmidt) takes about 2.3 n^3. No
    pivoting is needed for the step Jacobians the chord takes: J = -M/h + h/4 L_qq + a skew
    part + O(h) forces (`dmoc.simulation.step_jacobian`), whose symmetric part is definite
    while the mass term dominates (h omega_max < 2), so that every leading block is
    nonsingular and the elimination stable (ibid., Sec. 4.2, nonsymmetric positive definite
    systems); a pivot that vanishes all the same makes the step non-finite, and the
    line-search Newton redoes it."""
    n = J.size1()
    A = [[J[i, j] for j in range(n)] for i in range(n)]
    for k in range(n):
        A[k][k] = 1 / A[k][k]
        for i in range(k + 1, n):
            A[i][k] = A[i][k] * A[k][k]
            for j in range(k + 1, n):
                A[i][j] = A[i][j] - A[i][k] * A[k][j]
    L = ca.SX(n, n)
    U = ca.SX(n, n)
    for i in range(n):
        for j in range(n):
            (L if j < i else U)[i, j] = A[i][j]
    return ca.densify(L), ca.densify(U)


def chord_delta(L, U, g):
    """J_0^{-1} g = U^{-1} (I + L)^{-1} g for the factors of `chord_factors`, by forward and
    back substitution, 2 n^2 operations, shape (n, 1)."""
    n = U.size1()
    z = [None] * n
    for i in range(n):
        z[i] = g[i] - sum((L[i, j] * z[j] for j in range(i)), ca.SX(0))
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = (z[i] - sum((U[i, j] * x[j] for j in range(i + 1, n)), ca.SX(0))) * U[i, i]
    return ca.vertcat(*x)


def remaining_error(last, before):
    """The error the chord's iterates leave after an update of relative size `last` that
    followed one of size `before`, at the observed linear rate r = last / before: last r /
    (1 - r), the geometric tail; `last` itself when r >= STALLED_RATE (updates at the
    round-off floor, or diverging ones: the rate does not tell their tail, and
    `DiracStepper.accepted` asks the residual instead). Iterates that cycle between two
    points at round-off give rates 1 +- 1e-16, whose tail would read 1e16 times the update:
    `arm6` at rest, its rows at 1e-16, refused 9 % of 20000 steps so. Newton's error after an
    update of size d is O(d^2), hence the different thresholds of an accepted step."""
    return _tail(last, last / before)


def more_updates(last, before, rate_before):
    """Whether the chord takes a further update after updates of relative sizes `before` and
    `last`, the rate before them `rate_before` (`before` over the update's before it; inf
    when there was none): while the error left exceeds CHORD_STOP_TOL. That error is the
    geometric tail at the rate last / before (`remaining_error`), or, once `last` is at most
    ROUND_OFF_UPDATE, the tail at `rate_before` if that is smaller. An update is computed
    from the rows g at its iterate, whose round-off eps |p| (the momenta's size) J^{-1} ~ h
    M^{-1} carries into the update as up to cond M times eps |y|: a floor the chord's
    updates reach and do not go below, measured up to 6.9 eps relative over 2000 steps of
    a 12-joint chain (cond M ~1e5; 8 eps is ROUND_OFF_UPDATE). An update at the floor
    carries noise, and its rate over the update before says nothing of the contraction,
    which the rate before it, of two updates above the floor, still measures; without
    this, a step whose floor lies above CHORD_STOP_TOL takes all CHORD_ITERATIONS updates
    (27 % of the 12-joint chain's steps), its error left below round-off long before. The
    error left stays below CHORD_STOP_TOL: 20000 steps of the 12-joint chain end within
    7e-14 of the stop at the tail alone (`benchmarks/robots.py --versus-newton`)."""
    at_floor = ca.if_else(last <= ROUND_OFF_UPDATE, _tail(last, rate_before), ca.inf)
    return ca.fmin(remaining_error(last, before), at_floor) > CHORD_STOP_TOL


def _tail(last, rate):
    """last rate / (1 - rate) for a rate below STALLED_RATE, else `last` itself."""
    return ca.if_else(rate < STALLED_RATE, last * rate / (1 - rate), last)


def updates_converged(update, rows_at_tol, chord):
    """Whether the fast path's updates converged, elementwise over steps: the last relative
    `update` at most NEWTON_UPDATE_TOL; with `chord` updates, which converge linearly (their
    `update` output is `remaining_error`), also the error they leave at most
    CHORD_UPDATE_TOL, or, stalled at round-off, the rows below tol (`rows_at_tol`)."""
    converged = update <= NEWTON_UPDATE_TOL
    return converged & ((update <= CHORD_UPDATE_TOL) | rows_at_tol) if chord else converged
