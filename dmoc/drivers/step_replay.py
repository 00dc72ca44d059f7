"""The replay of a verdict step by step (a driver, issue 41): the simulator's step from every
knot of an optimum at once, each started from the optimum's own state there, instead of one
run from its start (`dmoc.diagnostics.replays`). The light verdict of a re-solve of an
already judged structure (`dmoc.drivers.verdict.judged_solve`; docs/verification.md,
"The light verdict of a re-solve").

Step k of a `simulate` run solves the step equations (37) from (q_k, p_k) by Newton's method
started from step k - 1's solution (the increment q_k - q_{k-1}, the multipliers, the
stage values less q_{k-1}), and the run that replays an optimum follows it from q_0, p_0.
Here every step starts from the optimum's q_k, p_k and its step k - 1 (step 0 as a run's
first step, from zero increments): the fast path of the same stepper, mapped over the N
steps in one call. When each step lands on the optimum's q_{k+1}, p_{k+1}, the root IPOPT
converged to is, at every step, the root the simulator's Newton iteration finds from
there; what a run adds is the growth, along the discrete flow, of the steps' round-off.
"""

import numpy as np

from .._util.cache import BoundedCache
from .._util.compiled import Background, compiler
from .._util.numeric import Evaluator
from ..principle.formulations import LagrangianPlus, as_formulation
from ..results.figure_rules import NUMPY, departures
from ..simulation.preparation import prepare_runs
from ..simulation.stepper import DiracStepper
from .verdict_checks import q_scale, scale

# keyed by (id of a problem's Discretization, variant): its `_CompiledStep`, which keeps
# the Discretization so that the id stays its own while the entry lives
_STEPS = BoundedCache(16, "step_replays")


def applies(problem, traj):
    """True when `step_departure` can judge the optimum `traj` of `problem`: the (+) forms
    of the Lagrangian equations (37), whose knot momenta are the momenta a run carries and
    whose step multipliers are its Newton unknowns, with at least one step."""
    return isinstance(as_formulation(traj.variant, problem.disc), LagrangianPlus) and traj.steps > 0


def step_departure(problem, traj):
    """The departures of the steps taken from every knot of the optimum `traj` of
    `problem` (module notes) from its next knot, by the simulator's compiled fast path;
    None while that is not loaded (the first call starts compiling it, or loading it from
    the cache folder, in the background: `dmoc._util.compiled.Background`; never without
    a C compiler) or when the fast path does not accept a step (a run would redo it with
    its line-search Newton method): the full replay judges such an optimum.

    Parameters
    ----------
    problem : OptimalControlProblem
    traj : Trajectory
        Its optimum, with `applies`.

    Returns
    -------
    (q departure, p departure, departures per knot) or None
        max_k |q_{k+1} - q_opt,k+1| over the span of the optimum's configurations, the
        same of p over max |p_opt| (`dmoc.drivers.verdict` measures a replay's so), and
        the larger of the two at each knot 1 ... N, shape (N,).
    """
    step = replay_stepper(problem, traj)
    N = traj.steps
    mapped = step.mapped(N)
    if mapped is None:
        return None
    n, layout = traj.q.shape[1], step.stepper.state
    state = np.zeros((N, layout.size))
    state[:, layout.slice("q")] = traj.q[:-1]
    state[:, layout.slice("p")] = traj.p[:-1]
    state[1:, layout.slice("dq")] = traj.q[1:-1] - traj.q[:-2]
    state[1:, layout.slice("nu")] = traj.lam[:-1]
    state[1:, layout.slice("ds")] = traj.s[:-1] - np.tile(traj.q[:-2], (1, traj.s.shape[1] // n))
    following, out = mapped(state.T, traj.u.T, np.full(N, traj.h))
    if not step.stepper.accepted(out.T).all():
        return None
    dq = departures(NUMPY, following[layout.slice("q")].T, traj.q[1:], q_scale(traj))
    dp = departures(NUMPY, following[layout.slice("p")].T, traj.p[1:], scale(np.abs(traj.p).max()))
    return float(dq.max()), float(dp.max()), NUMPY.maximum(dq, dp)


def replay_stepper(problem, traj):
    """The `_CompiledStep` of `problem`'s discretization and `traj`'s variant, made (and
    its compile started) on first use and kept."""
    return _STEPS.get((id(problem.disc), traj.variant), lambda: _CompiledStep(problem, traj))


class _CompiledStep:
    """The stepper of the verdict's replay for `problem`'s discretization and `traj`'s
    variant (its layouts and its acceptance of a step), the fast path of the stepper
    `simulate` takes by default (``jit=None``) built and compiled, or loaded from the
    cache folder, in the background, and mapped over N steps per N, each through its
    buffer."""

    def __init__(self, problem, traj):
        self.disc = problem.disc
        self.stepper = prepare_runs(problem.disc.with_step(traj.h), [
            dict(q0=traj.q[0], p0=traj.p[0], steps=1, controls=traj.u[:1], variant=traj.variant,
                 throw=False, jit=False)])[0].stepper
        stepper = self.stepper
        self.loading = None if compiler() is None else Background(lambda: _compiled_step(stepper))
        self.maps = {}

    def mapped(self, steps):
        """The Evaluator of the compiled step mapped over `steps` steps, or None while it
        is not loaded (for good without a C compiler or a library)."""
        loaded = None if self.loading is None else self.loading.functions
        if loaded is None:
            return None
        if steps not in self.maps:
            self.maps[steps] = Evaluator(loaded["step"].map(steps))
        return self.maps[steps]


def _compiled_step(stepper):
    """{"step": the fast path of `simulate`'s default stepper of `stepper`'s residual,
    tol and max_iter, loaded from its compiled library} (the library of its horizons of
    1, 2, 4, ... steps: the first is the step). Runs in the background thread."""
    library = DiracStepper(stepper.residual, stepper.tol, stepper.max_iter, native=None).library
    return {"step": library.load()[library.functions[0].name()]}

