"""Benchmark: what a smaller NLP buys a re-solve (issue 25): the DMOC NLP with its stage
values s condensed per step by an implicit function, against the NLP as dmoc states it.

The condensed NLP is built from the same transcription and the same step residual: at each
step the residual's "stage" rows (n_stages rows; they read q_k, q_{k+1}, lam_k, s_k, u_k
and h, not p_k) are solved for s_k by Newton (CasADi's ``fast_newton`` rootfinder, from the
stages on the chord), and the transcription's own f and g are evaluated at the full x with
those s; its variables are x without block "s", its rows g without the stage rows
("condensed s"). "condensed s, lam" also eliminates the interior multipliers lam_k[m:] with
the constraint rows of the higher Legendre moments (it keeps the end node's multiplier and
the zeroth moment). Their derivatives are CasADi's (the implicit function theorem through
the rootfinder), so the full NLP is also run with CasADi's derivatives of the same f and g
("full, AD") besides dmoc's own path ("full, dmoc": the derivatives assembled from the
terms, `dmoc.optimal_control.nlp.separable`, through `dmoc.optimal_control.solver.ipopt.solver`). Evaluations:
CasADi's virtual machine (VM), expanded to SX (not possible through a rootfinder), and C
(the five Functions compiled by dmoc's `Library`, as ``jit=True``; dmoc's own path with
``jit=True``).

Per problem (the four cases and N of `peers_resolve.py`: rolling disk lobatto4 N = 11 and
lobatto3 N = 31, knife edge lobatto3 N = 28 and lobatto4 N = 14), in one process, every
variant in turn per round: a cold solve at the original goal (dmoc's default guess, zero
multipliers) and warm re-solves at `--goals` goals near it and at the original goal, in a
cycle (from the previous optimum, primal and dual, clipped into the new bounds, as
`dmoc.optimal_control.solver.guess.start_point`), with dmoc's IPOPT options for each start
(`DEFAULT_IPOPT_OPTIONS`, `start_options`); medians over the rounds. Before timing, every
variant's optimum is checked against dmoc's (q and u, at the original goal and at every
re-solve goal). Columns: "fun" the nlpsol's t_wall_nlp_*
summed, "rest" the packed call's wall time less it, "Newton us" the compiled Newton
solutions of all steps alone, per call at the optimum.

    python benchmarks/condensed.py [--rounds 15] [--goals 5] [--cases 0 1 2 3]
"""

import argparse
import os
import platform
import sys
import time
from types import SimpleNamespace

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

from dmoc._util.compiled import Library  # noqa: E402
from dmoc.optimal_control.solver.guess import start_point  # noqa: E402
from dmoc.optimal_control.solver.ipopt import (DEFAULT_IPOPT_OPTIONS, PackedSolver, data_tolerances,  # noqa: E402
                                 iteration_count, solver as dmoc_solver, start_options)
from dmoc.principle.explicit import single_output, solved_rows  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nlp_functions import CASES, per_call  # noqa: E402
from peers_resolve import dmoc_problem, goals, moved  # noqa: E402

# Newton on the stage rows: stop at |rows| <= ABSTOL or |step| <= ABSTOL_STEP
NEWTON = {"abstol": 1e-14, "abstolStep": 1e-14, "max_iter": 50}
AGREEMENT = 1e-9        # |q, u (condensed) - q, u (dmoc)| at every optimum


def step_rows(problem, multipliers):
    """Function ``(z, y) -> rows`` of one step: the step residual's "stage" rows and, with
    `multipliers`, its constraint rows but the first m (the higher Legendre moments), as
    functions of the unknowns z = s (with `multipliers` [s; lam[m:]], the interior
    multipliers) and y = [q0; q1; lam (lam[:m] with `multipliers`); u; h]; taken from the
    residual the NLP imposes (its rows with the explicit p1 substituted,
    `dmoc.principle.explicit`). None of them reads p0."""
    R, m = problem.residual, problem.disc.system.m
    rows = single_output(R, "rows")
    sx = dict(zip(rows.name_in(), rows.sx_in()))
    lam = ca.SX.sym("lam", m if multipliers else R.n_lam)
    interior = ca.SX.sym("lam_interior", R.n_lam - lam.numel())
    out, layout = rows(**{**sx, "lam": ca.vertcat(lam, interior)})["rows"], solved_rows(R)
    chosen = out[layout.slice("stage")]
    if multipliers:
        chosen = ca.vertcat(chosen, out[layout.slice("constraint")][m:])
    if "p0" in sx and ca.depends_on(chosen, sx["p0"]):
        raise RuntimeError("the eliminated rows read p0: they cannot be solved per step")
    z = ca.vertcat(sx["s"], interior)
    y = ca.vertcat(sx["q0"], sx["q1"], lam, sx["u"], sx["h"])
    return ca.Function("eliminated_rows", [z, y], [chosen], ["z", "y"], ["rows"])


def condensed(problem, multipliers=False):
    """(nlp, keep_x, keep_g, newton): the NLP of `problem`'s transcription with block "s" of x (and
    with `multipliers` the interior multipliers lam[m:] of every step) replaced by the
    per-step Newton solution of the rows of `step_rows`, and those rows dropped. `keep_x`,
    `keep_g`: the entries of the full (scaled) x and g that it keeps, in order; `newton`:
    Function ``(x, p) -> z``, the Newton solutions of every step alone."""
    T, N, rule, m = problem.transcription, problem.steps, problem.disc.rule, problem.disc.system.m
    lay, n_x, n_g = T.x_layout, T.x_layout.size, T.g_layout.size
    if problem.final_time.free:
        raise RuntimeError("only a fixed final time (h in p)")
    every_x = np.arange(n_x)
    gone_x = lay.unpack(every_x, "s")
    dynamics, rows = T.g_layout.unpack(np.arange(n_g), "dynamics"), T.dynamics_rows
    gone_g = dynamics[rows.slice("stage")]
    if multipliers:
        gone_x = np.vstack([gone_x, lay.unpack(every_x, "lam")[m:]])
        gone_g = np.vstack([gone_g, dynamics[rows.slice("constraint")][m:]])
    keep_x, keep_g = np.setdiff1d(every_x, gone_x), np.setdiff1d(np.arange(n_g), gone_g)
    order = np.empty(n_x, dtype=int)        # x = [x_kept; z column by column][order]
    order[keep_x] = np.arange(keep_x.size)
    order[gone_x.ravel(order="F")] = keep_x.size + np.arange(gone_x.size)
    D = T.x_scale
    xc, p = ca.MX.sym("x", keep_x.size), ca.MX.sym("p", T.p_layout.size)
    placeholder = ca.vertcat(xc, ca.MX(gone_x.size, 1))[order.tolist()] * ca.DM(D)
    block = {k: lay.unpack(placeholder, k) for k in ("q", "lam", "u")}
    q = block["q"] + ca.repmat(p[T.p_layout.slice("q_ref")], 1, N + 1)
    q0, q1 = q[:, :N], q[:, 1:]
    lam = block["lam"][:m, :] if multipliers else block["lam"]
    h = ca.repmat(p[T.p_layout.slice("h")], 1, N)
    guess = ca.vertcat(*[q0 + c * (q1 - q0) for c in rule.stage_nodes],
                       ca.MX(gone_x.shape[0] - rule.n_stage_blocks * q.size1(), N))
    newton = ca.rootfinder("eliminated", "fast_newton", step_rows(problem, multipliers), NEWTON)
    z = newton.map(N)(guess, ca.vertcat(q0, q1, lam, block["u"], h))
    x = ca.vertcat(xc, ca.vec(z) / ca.DM(D[gone_x.ravel(order="F")]))[order.tolist()]
    full = ca.Function("fg", [T.nlp["x"], T.nlp["p"]], [T.nlp["f"], T.nlp["g"]])
    f, g = full(x, p)
    return ({"x": xc, "p": p, "f": f, "g": g[keep_g.tolist()]}, keep_x, keep_g,
            ca.Function("newton", [xc, p], [z], ["x", "p"], ["z"]))


def ad_functions(nlp):
    """The five Functions IPOPT calls, by CasADi's algorithmic differentiation of the MX
    `nlp` (as nlpsol derives them; the Hessian's upper triangle)."""
    x, p, f, g = (nlp[k] for k in ("x", "p", "f", "g"))
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g.numel())
    hess = ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])
    xp = ([x, p], ["x", "p"])
    return {"nlp_f": ca.Function("nlp_f", *xp[:1], [f], xp[1], ["f"]),
            "nlp_g": ca.Function("nlp_g", *xp[:1], [g], xp[1], ["g"]),
            "nlp_grad_f": ca.Function("nlp_grad_f", *xp[:1], [f, ca.densify(ca.gradient(f, x))],
                                      xp[1], ["f", "grad_f_x"]),
            "nlp_jac_g": ca.Function("nlp_jac_g", *xp[:1], [g, ca.jacobian(g, x)], xp[1], ["g", "jac_g_x"]),
            "nlp_hess_l": ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [hess],
                                      ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])}


def nlpsol(nlp, functions, warm, sizes):
    """A PackedSolver of `nlp` evaluated by `functions`, with dmoc's options for the start."""
    opts = {"print_time": False, "error_on_fail": False, "no_nlp_grad": True, "calc_lam_p": False,
            "cache": functions,
            **{"ipopt." + k: v for k, v in {**DEFAULT_IPOPT_OPTIONS, **start_options(warm)}.items()}}
    made = ca.nlpsol("bench", "ipopt", nlp, opts)
    n_x, n_g, n_p = sizes
    return PackedSolver(made, SimpleNamespace(x_layout=SimpleNamespace(size=n_x),
                                              g_layout=SimpleNamespace(size=n_g),
                                              p_layout=SimpleNamespace(size=n_p)))


class Variant:
    """One NLP and evaluation: a cold and a warm solver, the entries of the full x and g it
    keeps, its sizes, and its warm-start chain."""

    def __init__(self, label, cold, warm, keep_x, keep_g, functions, newton=None):
        self.label, self.cold, self.warm, self.keep_x, self.keep_g = label, cold, warm, keep_x, keep_g
        jac, hess = functions["nlp_jac_g"], functions["nlp_hess_l"]
        self.size = (keep_x.size, keep_g.size, jac.sparsity_out(1).nnz(), hess.sparsity_out(0).nnz())
        self.previous, self.newton, self.newton_time = None, newton, None

    def solve(self, problem, warm):
        """(the solution in the full x's unscaled units on the kept entries, its stats);
        from dmoc's cold start of `problem` or the previous optimum."""
        T = problem.transcription
        D, R, kx, kg = T.x_scale, T.g_scale, self.keep_x, self.keep_g
        lbx, ubx = (T.lbx / D)[kx], (T.ubx / D)[kx]
        if warm:
            last = self.previous
            x0, lam_x0, lam_g0 = np.clip(last["x"], lbx, ubx), last["lam_x"], last["lam_g"]
        else:
            x0, lam_x0, lam_g0 = start_point(problem, None)
            x0, lam_x0, lam_g0 = (x0 / D)[kx], (lam_x0 * D)[kx], (lam_g0 / R)[kg]
        solver = self.warm if warm else self.cold
        tic = time.perf_counter()
        sol = solver(x0=x0, p=T.p, lam_x0=lam_x0, lam_g0=lam_g0, lbx=lbx, ubx=ubx,
                     lbg=(T.lbg * R)[kg], ubg=(T.ubg * R)[kg])
        wall = time.perf_counter() - tic
        st = solver.stats()
        if not st["success"]:
            raise RuntimeError(f"{self.label}: {st['return_status']}")
        self.previous = sol
        fun = sum(v for k, v in st.items() if k.startswith("t_wall_nlp_"))
        return D[kx] * sol["x"], (wall, iteration_count(st), fun, st["n_call_nlp_g"], float(sol["f"][0]))


def variants(problem):
    """The variants of `problem` (built now, C compiled into dmoc's cache folder)."""
    T = problem.transcription
    sizes = (T.x_layout.size, T.g_layout.size, T.p_layout.size)
    x0 = start_point(problem, None)[0] / T.x_scale
    if data_tolerances(T, x0):
        raise RuntimeError("this problem raises IPOPT's tolerances: not compared here")
    every_x, every_g = np.arange(sizes[0]), np.arange(sizes[1])
    nlps = [("full, AD", T.nlp, every_x, every_g, None)]
    for label, multipliers in (("condensed s", False), ("condensed s, lam", True)):
        nlps.append((label, *condensed(problem, multipliers)))
    ad = {label: ad_functions(nlp) for label, nlp, *_ in nlps}
    out = []
    for evaluation in ("VM", "SX", "C"):
        cold, warm = (dmoc_solver(T, start_options(w), expand=evaluation == "SX", reuse=False,
                                  report=False, jit=evaluation == "C")[0] for w in (False, True))
        out.append(Variant(f"full, dmoc, {evaluation}", cold, warm, every_x, every_g,
                           T.separable.derivatives()))
        for label, nlp, kx, kg, newton in nlps:
            if evaluation == "SX" and label.startswith("condensed"):
                continue        # a rootfinder has no SX form
            own = ad[label]
            functions = {"VM": lambda: own, "SX": lambda: {k: f.expand() for k, f in own.items()},
                         "C": lambda: Library(own.values(), "condensed_bench").load()}[evaluation]()
            cold, warm = (nlpsol(nlp, functions, w, (kx.size, kg.size, sizes[2])) for w in (False, True))
            if evaluation == "C" and newton is not None:
                newton = Library([newton], "condensed_newton").load()["newton"]
            out.append(Variant(f"{label}, {evaluation}", cold, warm, kx, kg, own,
                               newton if evaluation == "C" else None))
    return out


def check(problem, name, targets, every, reference):
    """Solve the original goal cold and every goal warm with each variant, and compare its
    q and u with `reference`'s (the first variant, dmoc's own): the largest difference."""
    T = problem.transcription
    blocks = np.r_[T.x_layout.slice("q"), T.x_layout.slice("u")]
    worst = {}
    for v in every:
        x, _ = v.solve(problem, warm=False)
        pairs = [(x, 0)]
        for goal in targets[1:]:
            pairs.append((v.solve(moved(problem, name, goal), warm=True)[0], len(pairs)))
        v.optima = pairs
    for v in every:
        where = np.searchsorted(v.keep_x, blocks)
        worst[v.label] = max(np.abs(x[where] - reference.optima[i][0][blocks]).max() for x, i in v.optima)
    return worst


def measure(name, rule, N, rounds, count):
    """Rows of the table for one case."""
    targets = goals(name, count)
    problem = dmoc_problem(name, N, rule, targets[0])
    every = variants(problem)
    worst = check(problem, name, targets, every, every[0])
    bad = {k: w for k, w in worst.items() if not w <= AGREEMENT}
    if bad:
        raise RuntimeError(f"{name} {rule}: optima differ from dmoc's by {bad}")
    for v in every:                         # the compiled Newton solves alone, at the optimum
        if v.newton is not None:
            at = [v.previous["x"], problem.transcription.p]
            v.newton_time = per_call({"newton": v.newton}, at, 200, 7)["newton"]
    cold = {v.label: [] for v in every}
    warm = {v.label: [] for v in every}
    moved_problems = [moved(problem, name, g) for g in list(targets[1:]) + [targets[0]]]
    for _ in range(rounds):
        for v in every:                     # interleaved: each variant once per round
            cold[v.label].append(v.solve(problem, warm=False)[1])
            for p in moved_problems:
                warm[v.label].append(v.solve(p, warm=True)[1])
    return every, worst, {"cold": cold, "warm": warm}


def table(name, rule, N, every, worst, timed):
    ref = {kind: np.median([r[0] for r in timed[kind][every[0].label]]) for kind in timed}
    print(f"\n{name}, {rule}, N = {N}")
    print("| variant | x, g | nnz jac_g, triu hess | max abs dq, du | start | ms | it "
          "| fun ms | rest ms | / dmoc VM | g evals | Newton us |")
    print("|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for v in every:
        for kind in ("cold", "warm"):
            rows = np.array(timed[kind][v.label])
            wall, it, fun, evals, _ = np.median(rows, axis=0)
            newton = "" if v.newton_time is None else f"{1e6 * v.newton_time:.1f}"
            print(f"| {v.label} | {v.size[0]}, {v.size[1]} | {v.size[2]}, {v.size[3]} "
                  f"| {worst[v.label]:.1e} | {kind} | {1e3 * wall:.2f} | {it:g} "
                  f"| {1e3 * fun:.2f} | {1e3 * (wall - fun):.2f} | {wall / ref[kind]:.2f} "
                  f"| {evals:g} | {newton} |")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=15, help="rounds of every variant (default 15)")
    parser.add_argument("--goals", type=int, default=5, help="re-solve goals per round (<= 6)")
    parser.add_argument("--cases", type=int, nargs="+", default=list(range(len(CASES))),
                        help="indices into CASES (default all)")
    args = parser.parse_args(argv)
    print(f"casadi {ca.__version__}, python {platform.python_version()}, "
          f"load average {os.getloadavg()[0]:.2f} at the start")
    for i in args.cases:
        name, rule, N = CASES[i]
        table(name, rule, N, *measure(name, rule, N, args.rounds, args.goals))
    print(f"\nload average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
