"""The fast path of the simulator's step (`dmoc.simulation.stepper`): FAST_ITERATIONS
Newton updates unrolled from the warm start (each through the Schur complement of the
multipliers, `dmoc.simulation.schur_complement`), or for many unknowns and a dense Jacobian
chord updates with the Jacobian (`dmoc.simulation.step_jacobian`) factorized once, as many
as the step needs (`dmoc.simulation.chord_update`), then the step's end: the next state and
the outputs that decide whether the step is accepted. Newton's as one SX Function after
common-subexpression elimination, which the compiled library is generated from, or, for a
stepper that never compiles, as an MX Function calling the update's SX Function, which is
built in a fraction of the time for the same numbers; the chord's as an MX Function whose
conditionals call the SX Function of an update while the updates have not converged.
"""

import casadi as ca

from .._util import typed_ops
from .chord_update import (CHORD_ITERATIONS, FIRST_CHORD_UPDATES, chord_delta, chord_factors,
                           chord_suited, more_updates, remaining_error)
from .schur_complement import newton_update
from .step_jacobian import step_jacobian

FAST_ITERATIONS = 3


def fast_step(stepper, eliminate, rows=None):
    """The fast path's Function ``(state, u, h) -> (next, out)`` of `stepper` (a
    `DiracStepper`: its `equations`, `unknowns`, `symbols`, `wrap` and `chord`) from its
    symbolic `rows` (`step_rows`, built here when None), outputs dense
    (the horizons write through buffers that receive the nonzeros only: a structural zero
    would shift the columns).

    Newton's FAST_ITERATIONS updates: with `eliminate`, one SX Function after ``ca.cse``
    (sin(q_k) once, not per iteration), which the compiled library is generated from.
    Without (a stepper that never compiles, native=False: the verdict's replay), an MX
    Function calling the SX Functions of the Newton update FAST_ITERATIONS times and of the
    step's start and end once: the same operations on the same numbers as one SX Function
    holding every copy of the update, built in a fraction of its time (rolling disk,
    lobatto4: 9 against 21 ms), at 1-2 us more per step in the virtual machine
    (benchmarks/verdict.py). Elimination costs more to build there than it saves over a run
    (benchmarks/step_cost.py, "dirac-vm"). The chord's updates stop once converged: an MX
    Function in either case (`_chord_step`).
    """
    rows = step_rows(stepper) if rows is None else rows
    if stepper.chord:
        return _chord_step(stepper, rows, eliminate)
    state, u, h, params, guess = stepper.symbols(ca.SX)
    ys, ps, g, J = rows
    newton = ca.Function("newton_update", [ys, ps], [newton_update(g, ys, stepper.unknowns, J)])

    def updates(y, p):
        return _iterated(lambda y: newton(y, p), y, FAST_ITERATIONS)
    if eliminate:
        solved = stepper.wrap(state, params, *updates(guess, params))
        outputs = [ca.densify(o) for o in ca.cse(list(solved))]
        return ca.Function("dirac_step_fast", [state, u, h], outputs, ["state", "u", "h"],
                           ["next", "out"])
    start = ca.Function("step_start", [state, u, h], [params, guess])
    state, u, h = ca.MX.sym("state", state.numel()), ca.MX.sym("u", u.numel()), ca.MX.sym("h")
    params, guess = start(state, u, h)
    outputs = _ends(stepper, False)(state, u, h, *updates(guess, params))
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


def _chord_step(stepper, rows, eliminate):
    """The fast path of chord updates (`dmoc.simulation.chord_update`) of the step equations
    `rows` (`step_rows`) as an MX Function ``(state, u, h) -> (next, out)``: an SX Function
    of the step's start (dg/dy factorized at the warm start and the first update, which
    shares the rows' pass at the warm start with dg/dy), then the SX Function of one update
    FIRST_CHORD_UPDATES - 1 times and up to CHORD_ITERATIONS - FIRST_CHORD_UPDATES times
    more, each of these through a conditional (CasADi's Switch: C's ``if`` when compiled)
    that takes it only while the error the updates leave exceeds CHORD_STOP_TOL
    (`more_updates`, from the last update's size and rate and the rate before), and an SX
    Function of the step's end; the start and the end after ``ca.cse`` with `eliminate` (the
    update as it is). A step pays
    for the updates it needs, and the compiled code holds one update's instructions, not
    CHORD_ITERATIONS copies."""
    state, u, h, params, guess = stepper.symbols(ca.SX)
    ys, ps, g, J = rows
    factors = ca.Function("chord_factors", [ys, ps],
                          list(chord_factors(step_jacobian(stepper, g, ys, ps, J))))
    L, U = (ca.SX.sym(name, ys.numel(), ys.numel()) for name in "LU")
    chord = ca.Function("chord_update", [ys, ps, L, U], [chord_delta(L, U, g)])
    factorized = factors(guess, params)          # J at the warm start, factorized once a step
    y, last = _iterated(lambda y: chord(y, params, *factorized), guess, 1)
    begun = [params, y, last, *factorized]
    start = ca.Function("chord_start", [state, u, h], ca.cse(begun) if eliminate else begun)
    last, rate, error, more = (ca.SX.sym(name) for name in ("last", "rate", "error", "more"))
    y, relative = _iterated(lambda y: chord(y, ps, L, U), ys, 1)
    carried = [ys, last, rate, error, more, ps, L, U]
    further = ca.Function("chord_further", carried, [
        y, relative, relative / last, remaining_error(relative, last),
        more_updates(relative, last, rate)])
    if_needed = ca.Function.conditional(
        "chord_if_needed", [ca.Function("chord_kept", carried, carried[:5])], further)
    state, u, h = ca.MX.sym("state", state.numel()), ca.MX.sym("u", u.numel()), ca.MX.sym("h")
    params, y, last, L, U = start(state, u, h)
    rate, error, more = ca.MX(ca.inf), ca.MX(ca.inf), ca.MX(1)   # no rate yet; error, more unread
    for _ in range(FIRST_CHORD_UPDATES - 1):
        y, last, rate, error, more = further(y, last, rate, error, more, params, L, U)
    for _ in range(CHORD_ITERATIONS - FIRST_CHORD_UPDATES):
        y, last, rate, error, more = if_needed(more, y, last, rate, error, more, params, L, U)
    outputs = _ends(stepper, eliminate)(state, u, h, y, error)
    return ca.Function("dirac_step_fast", [state, u, h], outputs, ["state", "u", "h"], ["next", "out"])


def _ends(stepper, eliminate):
    """The step's end ``(state, u, h, y, update) -> (next, out)`` from its solution y
    (`DiracStepper.wrap`) as an SX Function, after ``ca.cse`` with `eliminate`."""
    state, u, h, params, guess = stepper.symbols(ca.SX)
    solved, update = ca.SX.sym("y", guess.numel()), ca.SX.sym("update")
    outputs = list(stepper.wrap(state, params, solved, update))
    outputs = [ca.densify(o) for o in (ca.cse(outputs) if eliminate else outputs)]
    return ca.Function("step_ends", [state, u, h, solved, update], outputs)


def _iterated(update, y, iterations):
    """(y after `iterations` updates ``y - update(y)`` from `y`, the last update's size
    relative to y: |delta|_inf / (1 + |y|_inf))."""
    for _ in range(iterations):
        delta = update(y)
        y = typed_ops.minus(y, delta)
    return y, typed_ops.divide(ca.norm_inf(delta), typed_ops.plus(1.0, ca.norm_inf(y)))
