"""The compiled step of the Dirac integrator: one step of the shared StepResidual solved by
Newton's method, over a horizon with `mapaccum`. Used by `simulate`; it owns no mechanics:
the residual says which rows to solve, the formulation how the carried momentum and the
multiplier it solves for enter the step (`Formulation.step_momentum`).

Each step solves every residual row but "right" for y = (dq, nu, ds): the increment of
the implicit end variable (q_{k+1} - q_k, or p_{k+1} - p_k for (39)), the multiplier nu at
q_k and the stage values less q_k; the other end variable enters the "right" rows linearly
(-p1 or -q1), so it follows explicitly. The fast path (`fast_path`, compiled to C or not)
unrolls Newton updates (through `schur_complement`) or a robot's chord updates
(`chord_update`); a step it does not converge is redone by CasADi's line-search Newton, and
where that fails by `continuation` in h. Compiled, its horizons of 1 ... CHUNK steps
(`step_blocks`) are one C library cached on disk, mapped over up to LOCKSTEP runs in
`lockstep` (`horizons_of`); a run that leaves goes on with `resume`.
"""

import time
import warnings

import casadi as ca
import numpy as np

from .._util import compiled
from ..principle.explicit import explicit_end
from .._util.layout import Layout
from .step_blocks import CHUNK, chunk_length, chunk_sizes
from .chord_update import updates_converged
from .continuation import continued_step
from .fast_path import fast_step, step_rows, uses_chord

NATIVE_AFTER_SECONDS = 0.5


def step_layouts(n_q, n, m, ns):
    """(unknowns, state, out) Layouts of a stepper whose configurations have n_q entries
    (q), momenta and increments n (p, dq, p0), multipliers m (nu) and stage values ns (ds, s)."""
    unknowns = Layout([("dq", n), ("nu", m), ("ds", ns)])
    state = Layout([("q", n_q), ("p", n), *((k, unknowns.numel(k)) for k in unknowns.blocks)])
    out = Layout([("p0", n), ("nu", m), ("s", ns), ("rnorm", 1), ("update", 1), ("scale", 1),
                  ("nonfinite", 1)])
    return unknowns, state, out


class DiracStepper:
    """Step map (q_k, p_k', u_k, h) -> (q_{k+1}, p_{k+1}', ...) of a StepResidual.

    Blocks (``state``, carried from step to step): q (q_k), p (p_k', the momentum carried
    in), and the Newton warm start dq (the previous increment), nu, ds. Blocks of the
    per-step output (``out``): p0 (the p_k the step used), nu, s, rnorm (max-norm of the
    solved rows), update (relative size of the last update; with `chord` updates, the error
    they leave), scale (1 + max abs of p_k and p_{k+1}, what rnorm is measured against) and
    nonfinite (how many entries of the rows, the next state and the outputs are NaN or
    infinite). The step h is an input, so one stepper serves every h.

    `native` picks how the fast path's horizons run: True, as the compiled C `library`
    (`dmoc._util.compiled.Library`, compiled at once unless cached on disk); False, in the
    virtual machine; None, compiled if cached, else once this stepper has spent
    NATIVE_AFTER_SECONDS in the virtual machine (about a compile, so a run costs at most
    about twice the better choice; also mid-run; never without a C compiler). `native` says
    how they run now; both compute the same, so switching changes no result.
    """

    def __init__(self, residual, tol, max_iter, native=False):
        self.residual, self.tol = residual, tol
        self.unknowns, self.state, self.out = self._layouts()
        self.equations = self._equations()
        self.chord = uses_chord(self, rows := step_rows(self))     # the rows and dg/dy built once
        self.fast = fast_step(self, native is not False, rows)
        self.max_iter, self._robust = max_iter, None
        self._use({})
        self.library = (compiled.Library([self._horizon(c) for c in chunk_sizes()], "dirac_step")
                        if native is not False else None)
        self.native, self.vm_seconds = False, 0.0
        self._auto = native is None and self.library.key is not None
        if native or (self._auto and self.library.cached()):
            self._go_native()

    def _layouts(self):
        """(unknowns, state, out) Layouts of the blocks named in the class docstring, of
        sizes n (q, p, dq, p0), m (nu) and n_stages (ds, s)."""
        R = self.residual
        return step_layouts(R.n, R.n, R.n_lam, R.n_stages)

    def _go_native(self):
        """Evaluate the horizons from now on with the compiled library. When compiling fails,
        `native=True` raises; the automatic choice warns and keeps the virtual machine."""
        try:
            library = self.library.load()
        except RuntimeError as err:
            if not self._auto:
                raise
            warnings.warn(f"{err}\nSimulating in CasADi's virtual machine instead.", RuntimeWarning)
            self._auto = False
            return
        self._use(dict(zip(chunk_sizes(), library.values())))
        self.native = True

    def _use(self, horizons):
        """Evaluate the chunks with `horizons` ({steps: Function} of 1, 2, 4, ..., CHUNK
        steps; the fast step's `mapaccum` of a length missing there is made when first
        used, `_horizon`) from now on: each through a buffer of its own, and, for runs in
        lockstep, through buffers of its map over 1, 2, 4, ..., LOCKSTEP runs, also made
        when first used (`horizons_of`). A replay of N steps in the virtual machine
        (``native=False``) builds only the lengths of its chunks: 3 of the 11 at N = 11."""
        self._horizons, self._chunks, self._mapped = dict(horizons), {}, {}

    def _horizon(self, steps):
        """The horizon of `steps` steps (a power of two up to CHUNK), made when first used."""
        if steps not in self._horizons:
            self._horizons[steps] = self.fast.mapaccum(f"horizon_{steps}", steps)
        return self._horizons[steps]

    @property
    def robust(self):
        """The line-search Newton step's Function (`_robust_step`), made when a step first
        needs it: most runs never do."""
        if self._robust is None:
            self._robust = self._robust_step(self.max_iter)
        return self._robust

    def horizons_of(self, steps, runs):
        """(buffer, evaluate) of the horizon of `steps` steps mapped over `runs` runs
        (a power of two up to LOCKSTEP): CasADi's serial map, which calls the one horizon
        (compiled or in the virtual machine) for each run in turn, on columns that hold
        the runs one after another: inputs state (runs, state.size), u (runs, steps,
        n_controls), h (runs * steps,), outputs next (runs, steps, state.size) and out
        (runs, steps, out.size), C-contiguous."""
        key = (steps, runs)
        if key not in self._mapped:
            mapped = self._horizon(steps).map(f"horizon_{steps}_x{runs}", "serial", runs, [], [])
            self._mapped[key] = mapped.buffer()
        return self._mapped[key]

    def native_if_due(self):
        """With `native` None, go native once the virtual machine has had its
        NATIVE_AFTER_SECONDS (before the next chunk)."""
        if self._auto and not self.native and self.vm_seconds >= NATIVE_AFTER_SECONDS:
            self._go_native()

    def _equations(self):
        """G(y, params) -> (g, p0, q1, p1) with params = (q0, p0', u, h): the equations, the
        momentum p_k they use and the next state.

        The residual's "right" rows give one end variable explicitly (the formulation's
        `explicit`: p1 for the Lagrangian forms and (43), q1 for (39)); the unknown dq is the
        increment of the other one from its value at the start of the step. Increments are
        substituted symbolically so that the velocities inside the residual are exact
        combinations of dq/h and ds/h (CasADi simplifies (q0 + dq) - q0): no cancellation
        when |q| is large, no rounding of q1 carried into p1, and the previous step's
        increments are a warm start.
        """
        R, n = self.residual, self.residual.n
        y, q0, pc0 = ca.SX.sym("y", self.unknowns.size), ca.SX.sym("q0", n), ca.SX.sym("p0", n)
        u, h = ca.SX.sym("u", R.n_controls), ca.SX.sym("h")
        Y = self.unknowns.split(y)
        p0, lam = R.formulation.step_momentum(R.system, q0, pc0, Y["nu"])
        explicit = R.formulation.explicit
        implicit, start = ("q1", q0) if explicit == "p1" else ("p1", p0)
        ends = {implicit: start + Y["dq"]}
        out = explicit_end(R)(q0=q0, p0=p0, lam=lam, s=self._stages(q0, Y["ds"]), u=u, h=h, **ends)
        ends[explicit] = out[explicit]
        return ca.Function("step_equations", [y, ca.vertcat(q0, pc0, u, h)],
                           [out["rows"], p0, ends["q1"], ends["p1"]],
                           ["y", "params"], ["g", "p0", "q1", "p1"])

    def _stages(self, q0, ds):
        """The stage values s = (q0, ..., q0) + ds."""
        return ca.repmat(q0, ds.numel() // q0.numel(), 1) + ds

    def wrap(self, state, params, sol, update):
        """Next state and outputs from a solution y = (dq, nu, ds) of the step equations,
        with what `accepted` needs computed in the step itself (in C when compiled): the
        scale of the momenta and the count of non-finite entries (CasADi's max-norm skips
        NaN, so rnorm alone cannot tell)."""
        g, p0, q1, p1 = self.equations(sol, params)
        Y = self.unknowns.split(sol)
        q0 = self.state.split(state)["q"]
        following = self.state.join({"q": q1, "p": p1, **Y})
        out = {"p0": p0, "nu": Y["nu"], "s": self._stages(q0, Y["ds"]), "rnorm": ca.norm_inf(g),
               "update": update, "scale": 1 + ca.fmax(ca.norm_inf(p0), ca.norm_inf(p1))}
        every = ca.vertcat(g, following, *out.values())
        out["nonfinite"] = ca.sum1(1 - (ca.fabs(every) < ca.inf))
        return following, self.out.join(out)

    def symbols(self, kind):
        """(state, u, h, params, warm start) symbols of kind SX or MX."""
        state = kind.sym("state", self.state.size)
        u, h = kind.sym("u", self.residual.n_controls), kind.sym("h")
        X = self.state.split(state)
        guess = ca.vertcat(*[X[k] for k in self.unknowns.blocks])
        return state, u, h, ca.vertcat(X["q"], X["p"], u, h), guess

    def _robust_step(self, max_iter):
        state, u, h, params, guess = self.symbols(ca.MX)
        y, p = ca.SX.sym("y", guess.numel()), ca.SX.sym("p", params.numel())
        G = ca.Function("G", [y, p], [self.equations(y, p)[0]])
        newton = ca.rootfinder("newton_step", "newton", G, {
            "abstol": self.tol, "abstolStep": 1e-3 * self.tol, "max_iter": max_iter,
            "error_on_fail": False})
        sol = newton(guess, params)
        return ca.Function("dirac_step_robust", [state, u, h],
                           list(self.wrap(state, params, sol, ca.MX(0))),
                           ["state", "u", "h"], ["next", "out"])

    def accepted(self, out):
        """Which steps count as converged, from their outputs (rows of `out`): every entry of
        the step finite, the residual below 1000 tol relative to the size of the momenta
        (`scale`: 1 + max abs(p_k), max abs(p_{k+1})), the updates converged
        (`chord_update.updates_converged`)."""
        at = {name: self.out.slice(name).start for name in ("rnorm", "update", "scale", "nonfinite")}
        rows, scale = out[:, at["rnorm"]], out[:, at["scale"]]
        return ((out[:, at["nonfinite"]] == 0) & (rows <= 1e3 * self.tol * scale)
                & updates_converged(out[:, at["update"]], rows <= self.tol * scale, self.chord))

    def _chunk(self, state, controls, steps, acc, out):
        """len(steps) fast steps from `state` as one mapaccum call, evaluated through
        CasADi's buffer interface straight into the rows of the time-major arrays `acc`
        and `out` (C-contiguous, so the rows of a chunk are one block of memory)."""
        c = len(steps)
        if c not in self._chunks:
            self._chunks[c] = self._horizon(c).buffer()
        buffer, evaluate = self._chunks[c]
        for i, a in enumerate((state, controls, steps)):
            buffer.set_arg(i, memoryview(np.ascontiguousarray(a, dtype=float)))
        buffer.set_res(0, memoryview(acc))
        buffer.set_res(1, memoryview(out))
        evaluate()

    def run(self, start, controls, h, law=None):
        """Steps from state `start` under `controls` (N, n_controls), stopping at the first step
        that neither Newton path converges, or at a KeyboardInterrupt (Ctrl-C); under a
        feedback `law` (`dmoc.simulation.feedback_law`) one step at a time.

        Returns (states (k + 1, state.size), `start` first, outputs (k, out.size), rnorm of
        the failed step (NaN when it turned non-finite) or None, number of steps redone by
        the robust path, whether a KeyboardInterrupt stopped the run, the steps k of those
        found by continuation in h). An interrupt arrives between chunks or inside one's
        evaluation; the k steps counted so far are accepted, the chunk it cut short dropped.
        """
        N = controls.shape[0]
        acc, out = np.empty((N + 1, self.state.size)), np.empty((N, self.out.size))
        acc[0] = start
        return self.resume(acc, out, controls, h, 0, redo=False, law=law)

    def resume(self, acc, out, controls, h, k, redo, law=None):
        """`run` from step `k` of arrays whose rows up to k (states) and k - 1 (outputs)
        are done, redoing step k with the line-search Newton first when `redo` (the fast
        path did not converge it): how a run that leaves the lockstep goes on
        (`dmoc.simulation.lockstep`) as `run` would have gone on at that step."""
        done, interrupted = [k, 0, []], False   # steps accepted, redone, continued: kept on Ctrl-C
        try:
            rnorm = self._redo(acc, out, controls, h, done) if redo else None
            if rnorm is None:
                rnorm = self._steps(acc, out, controls, h, done, law)
        except KeyboardInterrupt:
            rnorm, interrupted = None, True
        k, redone, continued = done
        return acc[:k + 1], out[:k], rnorm, redone, interrupted, continued

    def _steps(self, acc, out, controls, h, done, law=None):
        """Fill `acc` and `out` chunk by chunk (by steps under a `law`: controls[k] = law(k,
        acc[k]) first), counting in `done` = [steps accepted, redone, continued]; return the
        rnorm of a failed step (NaN when non-finite), or None."""
        N = controls.shape[0]
        steps = np.full(min(N, CHUNK), float(h))
        while done[0] < N:
            k = done[0]
            c = 1 if law else chunk_length(N - k)
            if law:
                controls[k] = law(k, acc[k])
            self.native_if_due()
            tic = time.perf_counter()
            self._chunk(acc[k], controls[k:k + c], steps[:c], acc[k + 1:k + 1 + c], out[k:k + c])
            if not self.native:
                self.vm_seconds += time.perf_counter() - tic
            ok = self.accepted(out[k:k + c])
            j = int(np.argmin(ok)) if not ok.all() else c
            done[0] = k + j
            if j < c:
                rnorm = self._redo(acc, out, controls, h, done)
                if rnorm is not None:
                    return rnorm
        return None

    def _redo(self, acc, out, controls, h, done):
        """Redo step k = done[0] with the line-search Newton, where that fails by continuation
        in h (`continued_step`); None when one converges, else the first's rnorm (or NaN)."""
        k = done[0]
        acc1, out1 = (np.array(x).T[0] for x in self.robust(acc[k], controls[k], h))
        if not self.accepted(out1[None, :])[0]:
            continued = continued_step(self, acc[k], controls[k], h)
            if continued is None:
                finite = out1[self.out.slice("nonfinite").start] == 0
                return float(out1[self.out.slice("rnorm").start]) if finite else np.nan
            acc1, out1 = continued
            done[2].append(k)
        acc[k + 1], out[k] = acc1, out1
        done[:2] = k + 1, done[1] + 1
        return None

