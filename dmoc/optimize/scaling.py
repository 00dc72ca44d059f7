"""The scaling of the DMOC NLP by the system's inertia (consumer 2 of the step residual):
IPOPT iterates on x / x_scale and imposes g_scale * g = 0, where x_scale gives the
momenta, the controls and the d'Alembert multipliers and impulses of (37)/(41) the size of
the inertia they act on, and g_scale divides the momentum rows by it. A system whose
degrees of freedom have inertias of different orders (a vehicle of 1e3 kg turning with a
yaw inertia of 1 kg m^2) otherwise gives IPOPT a KKT matrix whose blocks differ by those
orders; with equal inertias every factor is 1 and the NLP is unchanged.
"""

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache


_DATA = BoundedCache(64, "scaling_data")     # per system key: q -> (inertia, dF/du, A) at (q, 0, 0)


def inertia(system, q):
    """The inertia of each degree of freedom at q, shape (n,).

    Parameters
    ----------
    system : MechanicalSystem or HamiltonianSystem
        Its `inertia` (diag d2L/dv2 (q, 0), or 1 / diag d2H/dp2 (q, 0)).
    q : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (n,)
        Entries that are not positive and finite (degenerate directions: an LC circuit's
        capacitor-only loop, a point vortex, whose Lagrangian is linear in v) take the
        geometric mean of the others, and all are 1 when none is: the scaling is about
        ratios and never divides by a degenerate inertia.
    """
    return _usable(_mechanical_data(system, q)[0])


def _usable(M):
    """|M| with the entries that are not positive and finite replaced as `inertia` says."""
    M = np.abs(M)
    valid = np.isfinite(M) & (M > 0)
    mean = float(np.exp(np.log(M[valid]).mean())) if valid.any() else 1.0
    return np.where(valid, M, mean)


def acting_on(M, matrix):
    """The inertia each row of `matrix` (r, n) acts on: sum_i M_i |a_ri| / sum_i |a_ri|,
    shape (r,); 1 for zero rows. For the columns of dF/du (controls) and the rows of A(q)
    (d'Alembert multipliers and impulses)."""
    a = np.abs(np.asarray(matrix, dtype=float).reshape(-1, M.size))
    a = np.where(np.isfinite(a), a, 0.0)        # a singular direction at q: no weight
    weight = a.sum(axis=1)
    return np.where(weight > 0, a @ M / np.where(weight > 0, weight, 1.0), 1.0)


def nlp_scales(disc, formulation, x_layout, g_layout, dynamics_rows, q):
    """(x_scale, g_scale), shapes (x_layout.size,) and (g_layout.size,), of the DMOC NLP of
    `disc` and `formulation` with those layouts and the residual rows `dynamics_rows`
    imposed per step (`dmoc.optimize.transcription.Transcription`), from the inertia at q,
    shape (n,) (the transcription's `q_ref`).

    x_scale: p (momenta) by M_i; u by the inertia its force acts on (dF/du at (q_ref, 0,
    0)); lam, mu, nu by the inertia A(q_ref) acts on; q, s, velocities and h by 1.
    g_scale: 1 / M_i on the rows in momentum units, the formulation's `momentum_rows` of the
    residual (row r of a block of size n * j acts on degree of freedom r mod n) and the
    momentum boundary rows when the system's `momentum_residual` is in momentum units; 1 on
    the rest (constraint, velocity and path rows).
    Every factor is rounded to the nearest power of 2 (`power_of_two`).
    The objective is not scaled: dividing it by the cost of the cheapest scaled control
    made the NLP invariant to a change of units but cost the rolling disk's warm start an
    iteration (docs/performance.md).
    """
    sys, X, G = disc.system, x_layout, g_layout
    M, B, A = _mechanical_data(sys, q)
    M = _usable(M)
    on_lam = acting_on(M, A)
    by_block = {"p": M, "lam": np.tile(on_lam, disc.n_multipliers // max(sys.m, 1)),
                "mu": on_lam, "nu": on_lam, "u": np.tile(acting_on(M, B.T), len(disc.rule.control_nodes))}
    x_scale, g_scale = np.ones(X.size), np.ones(G.size)
    for name, scale in by_block.items():
        if X.numel(name):
            X.unpack(x_scale, name)[:] = scale[:, None]
    rows = dynamics_rows.slices()
    dynamics = G.unpack(g_scale, "dynamics")
    for name in formulation.momentum_rows:
        if name in rows:
            r = np.arange(rows[name].start, rows[name].stop)
            dynamics[r] = 1.0 / M[(r - rows[name].start) % sys.n][:, None]
    if sys.momentum_residual_units == "momentum":
        for end in ("start", "goal"):
            G.unpack(g_scale, end)[:] = 1.0 / M[:, None]
    return power_of_two(x_scale), power_of_two(g_scale)


def power_of_two(scale):
    """`scale` (array_like) rounded to the nearest power of 2 within the normal numbers
    (2^-1022 ... 2^1023), 1 where it is not positive and finite: scaling by it is exact in
    floating point, and problems whose inertia
    differs a little (a start heading of 0 or 0.1 rad) share one NLP `structure`, hence one
    solver and warm starts."""
    s = np.asarray(scale, dtype=float)
    valid = np.isfinite(s) & (s > 0)
    exponent = np.clip(np.round(np.log2(np.where(valid, s, 1.0))), -1022, 1023)   # normal numbers
    return np.where(valid, np.ldexp(1.0, exponent.astype(int)), 1.0)


def _mechanical_data(system, q):
    """(system.inertia (n,), dF/du (n, n_u), A (m, n)) at (q, 0, u = 0), from one Function
    per system key."""
    def build():
        qs, u = ca.SX.sym("q", system.n), ca.SX.sym("u", system.n_u)
        B = ca.jacobian(system.force(qs, ca.SX.zeros(system.n), u), u)
        return ca.Function("mechanical_data", [qs, u],
                           [system.inertia(qs), B, system.constraint_matrix(qs)])
    M, B, A = _DATA.get(system.key, build)(q, np.zeros(system.n_u))
    return (np.array(M).ravel(), np.array(B).reshape(system.n, system.n_u),
            np.array(A).reshape(system.m, system.n))
