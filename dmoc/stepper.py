"""The compiled step of the Dirac integrator: one step of the residual of (37)/(41) solved
for (q_{k+1} - q_k, nu, s) by Newton's method, over a horizon with `mapaccum`. Used by
`simulate`; it owns no mechanics, only the solution of the shared StepResidual.

Each step solves n + m (+ stages) equations for the increment q_{k+1} - q_k and the
multiplier: every residual row but "right", in which
p_{k+1} enters linearly (-p1), so p_{k+1} follows explicitly. Variant "+": the unknown
nu is lam_k. Variant "-": nu is the impulse mu with p_k = p_k' - A(q_k)^T mu (p_k' the
momentum carried in), and the residual's lam (at q_{k+1}) is left to the next step.
A fast path runs FAST_ITERATIONS unrolled Newton iterations (pure SX, optionally compiled to C);
a step it does not converge is redone by CasADi's line-search Newton rootfinder.
"""

import casadi as ca
import numpy as np

FAST_ITERATIONS = 3
CHUNK = 1024      # steps per compiled call; shorter calls use powers of two, so at most
                  # log2(CHUNK) + 1 horizons are ever built per stepper


class DiracStepper:
    """Step map (q_k, p_k', u_k) -> (q_{k+1}, p_{k+1}', ...) of a StepResidual.

    State (carried from step to step): (q_k, p_k', dq_k, nu_k, s_k), where the previous
    increment dq_k = q_k - q_{k-1}, nu_k and s_k serve as the Newton warm start. Per-step output: (p_k, nu_k, s_k,
    residual max-norm, relative size of the last Newton update).
    """

    def __init__(self, residual, tol, max_iter, jit=False):
        self.residual, self.tol = residual, tol
        n, m, ns = residual.n, residual.m, residual.n_stages
        self.sizes = (n, m, ns)
        self.state_size = 3 * n + m + ns
        self.equations = self._equations()
        self.fast = self._fast_step(jit)
        self.robust = self._robust_step(max_iter)
        self._chunks = {}

    def _equations(self):
        """G(y, params) -> (g, p0, p1) with y = (dq, nu, s), params = (q0, p0', u, h):
        the equations, the momentum p_k they use (p0' less the (-) impulse) and p_{k+1}.

        The unknown is the increment dq = q1 - q0, substituted symbolically so that the
        velocities inside the residual are dq/h exactly (CasADi simplifies (q0 + dq) - q0):
        no cancellation when |q| is large, and p1 carries no rounding of q1.
        """
        R, (n, m, ns) = self.residual, self.sizes
        y, q0, pc0 = ca.SX.sym("y", n + m + ns), ca.SX.sym("q0", n), ca.SX.sym("p0", n)
        u, h, p1 = ca.SX.sym("u", R.n_u), ca.SX.sym("h"), ca.SX.sym("p1", n)
        dq, nu, s = ca.vertsplit(y, [0, n, n + m, n + m + ns])
        q1 = q0 + dq
        if R.variant == "+":
            p0, lam = pc0, nu
        else:
            p0, lam = pc0 - ca.mtimes(R.disc.system.constraint_matrix(q0).T, nu), ca.SX.zeros(m)
        r = R(q0, p0, q1, p1, lam, s, u, h)
        right = r[R.rows["right"]]
        if not ca.is_equal(ca.jacobian(right, p1), -ca.SX.eye(n), 2):
            raise RuntimeError("the residual's right rows must be (...) - p1")
        rows = [r[R.rows[k]] for k in ("left", "stage", "constraint")]
        return ca.Function("step_equations", [y, ca.vertcat(q0, pc0, u, h)],
                           [ca.vertcat(*rows), p0, ca.substitute(right, p1, ca.SX.zeros(n))],
                           ["y", "params"], ["g", "p0", "p1"])

    def _wrap(self, state, params, sol, update):
        """Next state and outputs from a solution y = (dq, nu, s) of the step equations."""
        n, m, ns = self.sizes
        g, p0, p1 = self.equations(sol, params)
        q0 = state[:n]
        dq, nu, s = ca.vertsplit(sol, [0, n, n + m, n + m + ns])
        return (ca.vertcat(q0 + dq, p1, dq, nu, s),
                ca.vertcat(p0, nu, s, ca.norm_inf(g), update))

    def _symbols(self, kind):
        state = kind.sym("state", self.state_size)
        u, h = kind.sym("u", self.residual.n_u), kind.sym("h")
        n = self.sizes[0]
        guess = state[2 * n:]
        return state, u, h, ca.vertcat(state[:2 * n], u, h), guess

    def _fast_step(self, jit):
        state, u, h, params, y = self._symbols(ca.SX)
        ys = ca.SX.sym("y", y.numel())
        g = self.equations(ys, params)[0]
        newton_data = ca.Function("newton_data", [ys, params], [g, ca.jacobian(g, ys)])
        for _ in range(FAST_ITERATIONS):
            g, J = newton_data(y, params)
            delta = ca.solve(J, g)
            y = y - delta
        update = ca.norm_inf(delta) / (1 + ca.norm_inf(y))
        options = {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O2"]}} if jit else {}
        return ca.Function("dirac_step_fast", [state, u, h], list(self._wrap(state, params, y, update)),
                           ["state", "u", "h"], ["next", "out"], options)

    def _robust_step(self, max_iter):
        state, u, h, params, guess = self._symbols(ca.MX)
        y, p = ca.SX.sym("y", guess.numel()), ca.SX.sym("p", params.numel())
        G = ca.Function("G", [y, p], [self.equations(y, p)[0]])
        newton = ca.rootfinder("newton_step", "newton", G, {
            "abstol": self.tol, "abstolStep": 1e-3 * self.tol, "max_iter": max_iter,
            "error_on_fail": False})
        sol = newton(guess, params)
        return ca.Function("dirac_step_robust", [state, u, h],
                           list(self._wrap(state, params, sol, ca.MX(0))),
                           ["state", "u", "h"], ["next", "out"])

    def accepted(self, out):
        """Which per-step outputs (rows of `out`) count as converged."""
        rnorm, update = out[:, -2], out[:, -1]
        return np.isfinite(out).all(axis=1) & (rnorm <= 1e3 * self.tol) & (update <= 1e-6)

    def _chunk(self, c, state, controls, h):
        """c fast steps from `state` as one compiled mapaccum call, evaluated through
        CasADi's buffer interface straight into numpy arrays (time-major (c, size))."""
        if c not in self._chunks:
            self._chunks[c] = self.fast.mapaccum("horizon", c).buffer()
        buffer, evaluate = self._chunks[c]
        args = [np.ascontiguousarray(a, dtype=float) for a in (state, controls, np.full(c, h))]
        acc = np.empty((c, self.state_size))
        out = np.empty((c, sum(self.sizes) + 2))
        for i, a in enumerate(args):
            buffer.set_arg(i, memoryview(a))
        buffer.set_res(0, memoryview(acc))
        buffer.set_res(1, memoryview(out))
        evaluate()
        return acc, out

    def run(self, start, controls, h):
        """Steps from state `start` under `controls` (N, n_u), stopping at the first step
        that neither Newton path converges.

        Returns (states (k, state_size), outputs (k, ...), rnorm of the failed step or
        None, number of steps redone by the robust path).
        """
        states = [np.zeros((0, self.state_size))]
        outputs = [np.zeros((0, sum(self.sizes) + 2))]
        N, k, state, redone = controls.shape[0], 0, start, 0
        while k < N:
            c = min(CHUNK, 1 << ((N - k).bit_length() - 1))
            acc, out = self._chunk(c, state, controls[k:k + c], h)
            ok = self.accepted(out)
            j = int(np.argmin(ok)) if not ok.all() else c
            states.append(acc[:j]), outputs.append(out[:j])
            state, k = (acc[j - 1] if j else state), k + j
            if j < c:       # redo step k with the line-search Newton
                acc1, out1 = (np.array(x).T for x in self.robust(state, controls[k], h))
                if not self.accepted(out1)[0]:
                    return np.vstack(states), np.vstack(outputs), float(out1[0, -2]), redone
                states.append(acc1), outputs.append(out1)
                state, k, redone = acc1[0], k + 1, redone + 1
        return np.vstack(states), np.vstack(outputs), None, redone
