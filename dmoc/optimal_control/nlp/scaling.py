"""The scaling of the DMOC NLP by the system's inertia and the size of the motion (consumer
2 of the step residual): IPOPT iterates on x / x_scale and imposes g_scale * g = 0. Each
coordinate gets a length l_i in its own units (`lengths`: the length of the motion in the
metric of the inertia M, or the distance over which a constraint row turns, if shorter);
configurations are scaled by l, momenta by M l, the controls, d'Alembert multipliers and
impulses by what their force directions must carry (`covector_scale`), and every row by
the size of its terms. Each factor carries the units of what it scales, so the scaled NLP
is the same whatever the units of length and mass (millimetres or kilometres, grams or
tonnes), and a system whose degrees of freedom have inertias of different orders (a
vehicle of 1e3 kg turning with a yaw inertia of 1 kg m^2) gives IPOPT a KKT matrix of
blocks of one order.
"""

import casadi as ca
import numpy as np

from ..._util.cache import BoundedCache


_DATA = BoundedCache(64, "scaling_data")     # per system key: q -> (inertia, dF/du, A, dA/dq) at (q, 0, 0)
# per (system key, q): those values, read-only (a problem's scales, lengths and guess read them
# at its q_ref 3 times, an accuracy loop 7)
_VALUES = BoundedCache(64, "scaling_values")


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


def lengths(system, q, motion):
    """The length l_i of each coordinate in a motion, shape (n,), in the units of q_i
    (metres for a position, radians for an angle) whatever the units of length and mass.

    Parameters
    ----------
    system : MechanicalSystem or HamiltonianSystem
    q : ndarray, shape (n,)
        Where the inertia M and the constraint rows A(q) are evaluated (`q_ref`).
    motion : ndarray, shape (n,)
        goal - start, NaN where an end is free.

    Returns
    -------
    ndarray, shape (n,)
        The smaller of d / sqrt(M_i), with d^2 = sum_i M_i dq_i^2 the squared length of
        the motion in the metric of the inertia (how far coordinate i would move if it
        made the whole motion), and, with l those lengths, |a_r o l| / |da_r/dq_i o l|
        over the constraint rows a_r (the distance along q_i over which a row turns by
        its own size: 1 rad for the heading in (-sin theta, cos theta, 0)). Without a
        motion (no entry given at both ends, equal ends, or ends less than sqrt(machine
        epsilon), 1.5e-8, of that length apart: a parallel parking by d turns the heading
        by about sqrt(d), so a scale taken from so small a motion would blow the other
        coordinates up by 1/sqrt(d)) d^2 is the geometric mean of M, which makes l = 1 for
        equal inertias (and is not covariant).
    """
    M, _, A, dA = _mechanical_data(system, q)
    M = _usable(M)
    d2 = float(M @ np.nan_to_num(motion) ** 2)
    rest = float(np.exp(np.log(M).mean()))
    if not (np.isfinite(d2) and d2 > np.finfo(float).eps * rest):
        d2 = rest
    l = np.sqrt(d2 / M)
    turn = np.sqrt(((np.where(np.isfinite(dA), dA, 0.0) * l[None, :, None]) ** 2).sum(axis=1))
    size = row_scale(l, A)[:, None]
    bend = np.where(turn > 0, size / np.where(turn > 0, turn, 1.0), np.inf)
    return np.minimum(l, bend.min(axis=0, initial=np.inf))


def covector_scale(p, rows):
    """The scale of the scalars c_r that multiply the rows a_r of `rows` (r, n) in a
    momentum (or a force) c_r a_r: the controls in dF/du, the multipliers and impulses in
    A(q)^T. c_r fits c_r |a_ri| to the momentum scales p_i (shape (n,)) in relative terms,
    c_r = sum_i |a_ri| / p_i / sum_i (a_ri / p_i)^2 (least squares), which has the units
    of c_r whatever those of the coordinates; shape (r,), 1 for rows that are zero.
    Entries that are not finite (a singular direction at q) count 0."""
    a = np.abs(np.asarray(rows, dtype=float).reshape(-1, p.size))
    a = np.where(np.isfinite(a), a, 0.0) / p
    fit = (a ** 2).sum(axis=1)
    return np.where(fit > 0, a.sum(axis=1) / np.where(fit > 0, fit, 1.0), 1.0)


def row_scale(l, rows):
    """|a_r o l|_2 for each row a_r of `rows` (r, n), shape (r,): the size of a_r . dq for
    a motion dq of the coordinates' lengths l (`lengths`); entries that are not finite (a
    singular direction at q) count 0."""
    a = np.asarray(rows, dtype=float).reshape(-1, l.size)
    return np.sqrt(((np.where(np.isfinite(a), a, 0.0) * l) ** 2).sum(axis=1))


def nlp_scales(disc, formulation, layouts, dynamics_rows, q, motion, hulled=()):
    """(x_scale, g_scale), shapes (x_layout.size,) and (g_layout.size,), of the DMOC NLP of
    `disc` and `formulation` with `layouts` = (x_layout, g_layout) and the residual rows
    `dynamics_rows` imposed per step (`dmoc.optimal_control.nlp.transcription.Transcription`), from
    the inertia M at q, shape (n,) (the transcription's `q_ref`), and the motion goal -
    start, shape (n,) (NaN where an end is free), through the lengths l (`lengths`).

    x_scale: q, the velocities and the configuration stages by l; p and the momentum
    stages by M l; u by `covector_scale` of its force direction dF/du (at (q, 0, 0)) and
    lam, mu, nu by that of their row of A(q); h by 1 (the unit of time is the user's).
    g_scale: 1 / (M_i l_i) on the rows in momentum units (the formulation's
    `momentum_rows`; row r of a block of size n * j acts on degree of freedom r mod n, and
    the boundary rows when the system's `momentum_residual_units` is "momentum"), 1 / l_i
    on the rows in configuration or velocity units (the other "left", "right" rows and the
    boundary rows of a Hamiltonian system), 1 / |a_r o l| on the constraint and velocity
    rows (`row_scale`); 1 on the path rows; on the ``control_hull`` rows of the controls
    `hulled` (their order, tiled), 1 over the scale of each one's control in x.
    Every factor is rounded to the nearest power of 2 (`power_of_two`). The objective is
    not scaled: a cost stated in consistent units is the same in
    any units.
    """
    sys, (X, G) = disc.system, layouts
    M, B, A, _ = _mechanical_data(sys, q)
    M = _usable(M)
    l = lengths(sys, q, motion)
    p = M * l
    x_blocks = {"q": l, "v_start": l, "v_goal": l, "p": p, "s": _stage_scale(disc, l, p),
                "lam": np.tile(covector_scale(p, A), disc.n_multipliers // max(sys.m, 1)),
                "mu": covector_scale(p, A), "nu": covector_scale(p, A),
                "u": np.tile(covector_scale(p, B.T), len(disc.rule.control_nodes))}
    x_scale, g_scale = np.ones(X.size), np.ones(G.size)
    for name, scale in x_blocks.items():
        if X.numel(name):
            X.unpack(x_scale, name)[:] = scale[:, None]
    dynamics, rows = G.unpack(g_scale, "dynamics"), dynamics_rows.slices()
    for name, block in rows.items():
        per_coordinate = (1 / p if name in formulation.momentum_rows
                          else 1 / l if name in ("left", "right") else None)
        if name == "constraint":
            dynamics[block] = 1 / np.tile(row_scale(l, A), disc.n_multipliers // max(sys.m, 1))[:, None]
        elif per_coordinate is not None:
            dynamics[block] = per_coordinate[np.arange(block.stop - block.start) % sys.n][:, None]
    for end in ("start", "goal"):
        G.unpack(g_scale, end)[:] = (1 / p if sys.momentum_residual_units == "momentum" else 1 / l)[:, None]
        if G.numel(end + "_velocity"):
            G.unpack(g_scale, end + "_velocity")[:] = 1 / row_scale(l, A)[:, None]
    if G.numel("control_hull"):         # in units of their controls, as the control values in x
        hull = G.unpack(g_scale, "control_hull")
        hull[:] = 1 / np.resize(covector_scale(p, B.T)[list(hulled)], hull.shape[0])[:, None]
    return power_of_two(x_scale), power_of_two(g_scale)


def _stage_scale(disc, l, p):
    """The scale of the stage values, shape (n_stages,): the rule's own stage guess
    (`stage_guess`) from knots at the configuration scales l and at the momentum scales p,
    so that a stage that is a configuration gets l_i and one that is a momentum p_i."""
    knots, zero = (np.tile(l, (2, 1)), np.tile(p, (2, 1))), np.zeros((2, l.size))
    return (np.abs(disc.rule.stage_guess(knots[0], zero)) + np.abs(disc.rule.stage_guess(zero, knots[1])))[0]


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
    """(system.inertia (n,), dF/du (n, n_u), A (m, n), dA/dq (m, n, n) with [r, j, i] =
    dA_rj/dq_i) at (q, 0, u = 0), from one Function per system key; evaluated once per
    system key and q, the arrays read-only."""
    q = np.asarray(q, dtype=float)
    return _VALUES.get((system.key, q.tobytes()), lambda: _evaluated(system, q))


def _evaluated(system, q):
    """`_mechanical_data` evaluated, its arrays flagged read-only."""
    def build():
        qs, u = ca.SX.sym("q", system.n), ca.SX.sym("u", system.n_u)
        B = ca.jacobian(system.force(qs, ca.SX.zeros(system.n), u), u)
        A = system.constraint_matrix(qs)
        return ca.Function("mechanical_data", [qs, u],
                           [system.inertia(qs), B, A, ca.jacobian(ca.vec(A.T), qs)])
    M, B, A, dA = _DATA.get(system.key, build)(q, np.zeros(system.n_u))
    n, m = system.n, system.m
    values = (np.array(M).ravel(), np.array(B).reshape(n, system.n_u),
              np.array(A).reshape(m, n), np.array(dA).reshape(m, n, n))
    for a in values:
        a.flags.writeable = False
    return values
