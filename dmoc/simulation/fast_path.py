"""The fast path of the simulator's step (`dmoc.simulation.stepper`): FAST_ITERATIONS
Newton updates unrolled from the warm start (each through the Schur complement of the
multipliers, `dmoc.simulation.schur_complement`), or for many unknowns and a dense Jacobian
CHORD_ITERATIONS chord updates with the Jacobian (`dmoc.simulation.step_jacobian`) factorized
once (`dmoc.simulation.chord_update`),
then the step's end: the next state and the outputs that decide whether the step is accepted. As one SX Function after
common-subexpression elimination, which the compiled library is generated from; or, for a
stepper that never compiles, as an MX Function calling the update's SX Function, which is
built in a fraction of the time for the same numbers.
"""

import casadi as ca

from .._util import typed_ops
from .chord_update import (CHORD_ITERATIONS, chord_delta, chord_factors, chord_suited,
                           remaining_error)
from .schur_complement import newton_update
from .step_jacobian import step_jacobian

FAST_ITERATIONS = 3


def fast_step(stepper, eliminate, rows=None):
    """The fast path's Function ``(state, u, h) -> (next, out)`` of `stepper` (a
    `DiracStepper`: its `equations`, `unknowns`, `symbols` and `wrap`) from its symbolic
    `rows` (`step_rows`, built here when None), outputs dense
    (the horizons write through buffers that receive the nonzeros only: a structural zero
    would shift the columns).

    With `eliminate`, one SX Function after ``ca.cse`` (sin(q_k) once, not per
    iteration), which the compiled library is generated from. Without (a stepper that never
    compiles, native=False: the verdict's replay), an MX Function calling the SX Functions
    of the Newton update FAST_ITERATIONS times and of the step's start and end once: the
    same operations on the same numbers as one SX Function holding every copy of the
    update, built in a fraction of its time (rolling disk, lobatto4: 9 against 21 ms), at
    1-2 us more per step in the virtual machine (benchmarks/verdict.py). Elimination costs
    more to build there than it saves over a run (benchmarks/step_cost.py, "dirac-vm").
    """
    state, u, h, params, guess = stepper.symbols(ca.SX)
    updates = _updates(stepper, step_rows(stepper) if rows is None else rows)
    if eliminate:
        solved = stepper.wrap(state, params, *updates(guess, params))
        outputs = [ca.densify(o) for o in ca.cse(list(solved))]
        return ca.Function("dirac_step_fast", [state, u, h], outputs, ["state", "u", "h"],
                           ["next", "out"])
    solved, update = ca.SX.sym("y", guess.numel()), ca.SX.sym("update")
    start = ca.Function("step_start", [state, u, h], [params, guess])
    ends = ca.Function("step_ends", [state, u, h, solved, update],
                       [ca.densify(o) for o in stepper.wrap(state, params, solved, update)])
    state, u, h = ca.MX.sym("state", state.numel()), ca.MX.sym("u", u.numel()), ca.MX.sym("h")
    params, guess = start(state, u, h)
    outputs = ends(state, u, h, *updates(guess, params))
    return ca.Function("dirac_step_fast", [state, u, h], outputs, ["state", "u", "h"], ["next", "out"])


def step_rows(stepper):
    """(y, params, g, J) of `stepper` (a `DiracStepper`): SX symbols of the unknowns and of
    the parameters, the step equations g(y, params) and J = dg/dy, built once for both
    `uses_chord` and the updates of `fast_step`."""
    ys, params = ca.SX.sym("y", stepper.unknowns.size), stepper.symbols(ca.SX)[3]
    g = stepper.equations(ys, params)[0]
    return ys, params, g, ca.jacobian(g, ys)


def uses_chord(stepper, rows):
    """Whether the fast path of `stepper` (a `DiracStepper`) is to take chord updates
    (`dmoc.simulation.chord_update.chord_suited` of its step Jacobian, of `step_rows`)."""
    return chord_suited(rows[3].sparsity, stepper.unknowns)


def _updates(stepper, rows):
    """``(y, params) -> (y after the fast path's updates from y, the size of the last
    update relative to y, |delta|_inf / (1 + |y|_inf), or for the chord the error it
    leaves, `chord_update.remaining_error`)``, through SX Functions of one update (and
    of the chord's factorization, when `stepper.chord`) of the step equations `rows`
    (`step_rows`), which take SX and MX arguments alike."""
    ys, params, g, J = rows
    if not stepper.chord:
        newton = ca.Function("newton_update", [ys, params], [newton_update(g, ys, stepper.unknowns, J)])
        return lambda y, p: _iterated(lambda y: newton(y, p), y, FAST_ITERATIONS)
    factors = ca.Function("chord_factors", [ys, params],
                          list(chord_factors(step_jacobian(stepper, g, ys, params, J))))
    Q, R = (ca.SX.sym(name, ys.numel(), ys.numel()) for name in "QR")
    chord = ca.Function("chord_update", [ys, params, Q, R], [chord_delta(Q, R, g)])

    def chord_iterated(y, p):
        QR = factors(y, p)        # J at the warm start, factorized once
        y, before = _iterated(lambda y: chord(y, p, *QR), y, CHORD_ITERATIONS - 1)
        delta = chord(y, p, *QR)
        y = y - delta
        return y, remaining_error(ca.norm_inf(delta) / (1 + ca.norm_inf(y)), before)
    return chord_iterated


def _iterated(update, y, iterations):
    """(y after `iterations` updates ``y - update(y)`` from `y`, the last update's size
    relative to y: |delta|_inf / (1 + |y|_inf))."""
    for _ in range(iterations):
        delta = update(y)
        y = typed_ops.minus(y, delta)
    return y, typed_ops.divide(ca.norm_inf(delta), typed_ops.plus(1.0, ca.norm_inf(y)))
