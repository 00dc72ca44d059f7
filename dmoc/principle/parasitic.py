"""The principle stage's stability test for degenerate Lagrangians: the growth of the
alternating (parasitic) mode of the step equations (37). On L linear in v the step map
(q_k, p_k) -> (q_{k+1}, p_{k+1}) has twice the dimension of the motion; the extra roots of
its linearization sit near -1 (midpoint, trapezoid, lobatto4; near +1 for lobatto3), and
for the trapezoid on a nonlinear flow the alternating mode they carry grows along the
motion. `step_residual` runs the test next to the one-step-map test
(`dmoc.principle.one_step`) and warns (docs/degenerate.md, "The alternating mode").
"""

import warnings

import casadi as ca
import numpy as np

from .._util.cache import BoundedCache
from ..discrete.degenerate import is_degenerate, sample_states
from ..errors import ParasiticModeWarning

STEPS = 6000               # length of the test motion: TURNS turns
STEPS_PER_RADIAN = 40      # its step: 1/(40 omega), omega the rate of the motion
TURN = int(2 * np.pi * STEPS_PER_RADIAN)
TURNS = STEPS // TURN
RATE_STEPS = 20            # steps of the first run that give omega
NEWTON_ITERATIONS = 4
NEWTON_TOLERANCE = 1e-10
EXCITATION = 1e-2          # offset of the start's momentum, relative to |p_0|
GROWTH_LIMIT = 5.0

_GROWTH = BoundedCache(32, "alternating_growth")


def check_alternating_mode(disc, plus_residual):
    """Warn (ParasiticModeWarning) when the alternating mode of the step equations of
    `disc` grows along a representative motion of a degenerate Lagrangian.

    Parameters
    ----------
    disc : Discretization
    plus_residual : callable
        Returns the (+) StepResidual of `disc`; called only when the growth for this system,
        rule and h is not known yet.

    Notes
    -----
    Regular Lagrangians have no parasitic roots and are not tested. The growth
    (`alternating_growth`) is computed once per system, rule and step h: it depends on h
    through the rate of the motion measured at h and the cap STEPS_PER_RADIAN h on the
    test's step.
    """
    if not is_degenerate(disc.system):
        return
    growth = _GROWTH.get((disc.key, disc.h),
                         lambda: alternating_growth(plus_residual(), disc.system, disc.h))
    if growth > GROWTH_LIMIT:
        warnings.warn(ParasiticModeWarning(
            f"`rule` {disc.rule.name!r} has an alternating (parasitic) mode that grows on this "
            f"degenerate Lagrangian: over {TURNS} turns of a representative motion at h = "
            f"{disc.h:.3g} it grew {growth:.3g}-fold. Once excited (a start off p = dL/dv, "
            f"forces, controls, round-off) it swamps long runs. {_remedy(disc.rule.name)} "
            f"(docs/degenerate.md, 'The alternating mode')."), stacklevel=3)


def _remedy(rule):
    """What to do instead of the rule named `rule`: rule='midpoint', whose alternating mode
    stays bounded on the measured systems (docs/degenerate.md), or, on the midpoint rule
    itself, rule='lobatto4' and a smaller h."""
    if rule != "midpoint":
        return ("Use rule='midpoint', whose samples (q_k + q_{k+1})/2 do not see the "
                "alternating mode")
    return ("The midpoint rule's samples (q_k + q_{k+1})/2 cancel the alternating mode, so "
            "a growth here points at a motion the test's steps at this h do not resolve "
            "rather than at the rule: take a smaller h, or use rule='lobatto4'")


def alternating_growth(R, system, h):
    """How much the alternating mode of the step equations of `R` grows along a motion:
    the largest factor over the starts of `sample_states` (1.0 for a start whose motion the
    steps cannot follow or which does not move).

    Parameters
    ----------
    R : StepResidual
        The (+) residual.
    system : MechanicalSystem
    h : float
        The step of a first run from each start, which gives the flow's rate there.

    Notes
    -----
    From a start z_0 = (q, dL/dv(q, v)) the step map z_{k+1} = (q_{k+1}, p_{k+1}) of (37)
    is iterated (Newton on the rows left, stage, constraint in (q_{k+1}, lam, s); p_{k+1}
    from the row right). A first run at `h` gives the rate of the motion (`_rate`:
    |q''|/|q'|, omega^2 r / (omega r) on a circle). The test run then starts from p_0 + e,
    e the projection of EXCITATION max(1, |p_0|) (1, ..., 1) on the momenta dL/dv gives
    near (q, v) (the range of its derivative in (q, v)): it excites the alternating mode as
    a start off p = dL/dv(q, .) or a force does, but gives no momentum that L never does
    (a coordinate without kinetic energy keeps p = 0; a start off it makes even the
    midpoint rule drift, docs/degenerate.md). It takes STEPS steps of
    1/(STEPS_PER_RADIAN omega), TURNS turns whatever `h` (but at most STEPS_PER_RADIAN h,
    for a motion that hardly turns, as an opposite vortex pair's): the alternating mode obeys an
    equation of its own, whose growth per unit time does not depend on the step to leading
    order. Its amplitude in q is the fourth difference |delta^4 q_k|/16 (A for a component
    (-1)^k A, O((omega h)^4) on the smooth motion); the growth is its largest value over the
    last third of the run divided by that over the first turn. A run whose Newton
    iterations stop converging is judged on the steps before (at least two turns).
    """
    probe, orbit = _orbit(R, RATE_STEPS + 1), _orbit(R, STEPS)
    qs, vs = ca.SX.sym("q", system.n), ca.SX.sym("v", system.n)
    p = system.momentum(qs, vs)
    momentum = ca.Function("momentum", [qs, vs], [p, ca.jacobian(p, ca.vertcat(qs, vs))])
    growths = []
    for q, v in sample_states(system):
        p, B = (np.array(a) for a in momentum(q, v))
        z = np.r_[q, p.ravel()]
        omega = _rate(probe, R, z, h)
        if omega:
            e = np.full(R.n, EXCITATION * max(1.0, np.abs(p).max()))
            z[R.n:] += B @ np.linalg.lstsq(B, e, rcond=None)[0]
            step = min(1.0 / (STEPS_PER_RADIAN * omega), STEPS_PER_RADIAN * h)
            growths.append(_growth(_positions(orbit, R, z, step)))
    return max(growths, default=1.0)


def _rate(probe, R, z, h):
    """The rate omega of the motion from z: the median over its first RATE_STEPS steps of
    |q_{k+1} - 2 q_k + q_{k-1}| / (h |q_{k+1} - q_k|), at h or, where Newton fails, at
    h/4 or h/16; 0.0 when the motion cannot be followed or does not move."""
    for step in (h, h / 4, h / 16):
        q = _positions(probe, R, z, step)
        if q is not None and len(q) == RATE_STEPS + 2:
            moved = np.linalg.norm(np.diff(q, axis=0), axis=1)
            if not np.all(moved > 0):
                return 0.0
            bent = np.linalg.norm(np.diff(q, 2, axis=0), axis=1)
            return float(np.median(bent / (step * moved[1:])))
    return 0.0


def _orbit(R, count):
    """The Function (y_0, z_0, h) -> (q_1 ... q_count, residual norms) of `count` steps of
    the step map of R, each NEWTON_ITERATIONS Newton iterations from the last solution."""
    x = {name: ca.SX.sym(name, R.inputs.numel(name)) for name in R.inputs.blocks}
    r = R.function(**{**x, "p1": ca.SX.zeros(R.n), "u": ca.SX.zeros(R.n_controls)})["r"]
    rows = ca.vertcat(*[r[R.rows[k]] for k in ("left", "stage", "constraint")])
    y, z, h = ca.vertcat(x["q1"], x["lam"], x["s"]), ca.vertcat(x["q0"], x["p0"]), x["h"]
    parts = ca.Function("parts", [y, z, h], [rows, ca.jacobian(rows, y), r[R.rows["right"]]])
    Y0, Z, H = ca.MX.sym("y", y.numel()), ca.MX.sym("z", z.numel()), ca.MX.sym("h")
    Y = Y0
    for _ in range(NEWTON_ITERATIONS):
        g, G, _ = parts(Y, Z, H)
        Y = Y - ca.solve(G, g)
    g, _, p1 = parts(Y, Z, H)
    one = ca.Function("step", [ca.vertcat(Y0, Z), H], [ca.vertcat(Y, Y[:R.n], p1), ca.norm_inf(g)])
    return one.mapaccum("orbit", count)


def _positions(orbit, R, z, h):
    """q_0, q_1, ... (k + 1, n) from z_0 = (q_0, p_0) at the step h, up to the last step
    before Newton first misses NEWTON_TOLERANCE (all `count` steps of `orbit` when it never
    does); None when the first step misses it."""
    n = R.n
    guess = np.r_[z[:n], np.zeros(R.n_lam), np.tile(z[:n], R.n_stages // n)]
    try:
        states, residuals = (np.array(a) for a in orbit(np.r_[guess, z], h))
    except RuntimeError:            # a non-finite value on the way: the motion is not followed
        return None
    q = states[guess.size:guess.size + n].T
    converged = np.abs(residuals.ravel()) <= NEWTON_TOLERANCE * (1.0 + np.abs(q).max(axis=1))
    k = converged.size if converged.all() else int(np.argmin(converged))
    return np.vstack([z[:n], q[:k]]) if k else None


def _growth(q):
    """The growth of the alternating amplitude |delta^4 q_k|/16 of the positions q (K, n)
    from their first turn to their last third (1.0 for fewer than two turns)."""
    if q is None or len(q) < 2 * TURN:
        return 1.0
    alternating = np.linalg.norm(q[4:] - 4 * q[3:-1] + 6 * q[2:-2] - 4 * q[1:-3] + q[:-4], axis=1) / 16
    return float(alternating[-len(alternating) // 3:].max() / alternating[:TURN].max())
