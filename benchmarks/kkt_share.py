"""Benchmark: IPOPT's share of a warm re-solve, dmoc against rockit, in one process (issue
25; docs/performance.md, "IPOPT's share of a re-solve, dmoc against rockit").

Rolling-disk steering at the N of `peers_resolve.py`'s accuracy scan (dmoc lobatto4
N = 11, rockit 42 intervals; `--problem knife` for knife-edge parking, dmoc lobatto3
N = 28, rockit 62): dmoc's raw re-solve compiled to C (``solve(problem.with_boundary(...),
guess=previous, jit=True)``) and rockit's function re-solve compiled to C (``to_function``
of goal, start x and multipliers, CasADi ``jit``, gcc -O2), each also with the other's
way of solving the KKT systems (dmoc's warm re-solves take IPOPT's ``fast_step_computation``
"yes", no residual of the KKT solves, since the ninth pass; rockit IPOPT's default "no"),
called in turn goal by goal over `peers_resolve.py`'s cycle of goals,
`--repeat` times (with `--rotate`, the method called first turns goal by goal: in the
fixed order dmoc's first row follows rockit's and pays the caches they leave; turning
keeps the cyclic order, so that row still follows rockit's last; with `--blocks`, each
method re-solves the whole cycle of goals in a row, as a user's loop does, the methods in
turn and their order reversed cycle by cycle, so that a re-solve follows its own method's
but for the first of a block). Per method
the medians per re-solve of: the call's wall time; IPOPT's as CasADi records it (``t_wall_total``, the nlpsol alone: for dmoc without the packed
call's NumPy conversions); its part in function evaluations (``t_wall_nlp_*``); the rest
of IPOPT (MUMPS and IPOPT's own work); the time outside IPOPT; the iterations; and the
mean number of calls of each NLP Function per re-solve. Then a re-solve at the goal just
solved, from its own optimum (0 iterations: the per-call set-up of CasADi's interface and
IPOPT and one evaluation of each Function, no factorization), and the structure: the KKT
matrix IPOPT factorizes (variables without the fixed ones, rows, nonzeros of the
Jacobian and of the Hessian's triangle, from IPOPT's journal) and MUMPS's factors (entries,
INFOG(29), and operations of one factorization's node eliminations, RINFO(3), from
MUMPS's report at ``mumps_print_level`` 2). A fifth row re-solves dmoc with IPOPT's
``fixed_variable_treatment`` "make_parameter", which computes the bound multipliers of the
fixed variables at every iteration (a gradient each; dmoc's default "make_parameter_nodual"
leaves them to `dmoc.optimal_control.solver.fixed_multipliers`, made when result.lam_x is read): the
same iterates, dmoc's default before the fourth pass. The last row is rockit's compiled
re-solve followed by the reading of its return status (``resolve.stats()``): rockit's
function returns IPOPT's last iterate without a word when IPOPT fails, so a loop that acts
only on converged re-solves reads it; dmoc's re-solve reads it inside `solve`.
Last, dmoc's packed IPOPT call with its stacked input handed to CasADi as a NumPy array
(before "IPOPT's share of a re-solve") and through the packed Function's buffer
(`dmoc.optimal_control.solver.ipopt.PackedSolver` since "The Python around IPOPT, third pass";
the list of floats in between is no longer timed), alternating, at an optimum: the same
bits, the time of each.
With `--pieces`, the pieces of dmoc's re-solve outside IPOPT are timed where they run, in
the loop above ("dmoc raw C" only; the caches as IPOPT and rockit leave them): each
function `solve` calls before and after the packed IPOPT call, the call itself less
IPOPT's own time, and `with_boundary`; medians per re-solve. Their wrappers (a clock read
before and after each) run in every dmoc row, which then costs a few microseconds more.

    /work/venv-peers/bin/python benchmarks/kkt_share.py [--repeat 40] [--problem disk|knife] [--rotate | --blocks] [--pieces]
"""

import argparse
import gc
import os
import re
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("GFORTRAN_UNBUFFERED_PRECONNECTED", "y")    # MUMPS's report written as it goes

import numpy as np  # noqa: E402

import peers_resolve as peers  # noqa: E402

PROBLEMS = {"disk": ("rolling disk", "lobatto4", 11, 42), "knife": ("knife edge", "lobatto3", 28, 62)}
# a journal at print level 8 and MUMPS's statistics (mumps_print_level 2, on the standard output)
REPORT = {"output_file": tempfile.mkstemp(prefix="kkt-share-", suffix=".txt")[1], "file_print_level": 8,
          "mumps_print_level": 2}
FUNCTIONS = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")


class Pieces:
    """Clocks around the pieces of dmoc's re-solve outside IPOPT (`--pieces`): each
    function of `dmoc.optimal_control.solve` that `solve` calls around the packed IPOPT call,
    the call itself (its IPOPT time subtracted when printed), the solver's statistics read
    by `solve` (not those the benchmark reads after it), and `with_boundary`. `record` is
    True while a re-solve to count runs, those of the loop over the goals while `active`;
    `seconds` holds one {piece: s} per re-solve."""

    SOLVE = ("start_point", "data_tolerances", "ipopt_solver", "_values_at_x", "_statistics", "_outcome",
             "_result")

    def __init__(self):
        import importlib
        solve = importlib.import_module("dmoc.optimal_control.solver.solving")
        ipopt = importlib.import_module("dmoc.optimal_control.solver.ipopt")
        problem = importlib.import_module("dmoc.optimal_control.statement.problem")
        self.record, self.active, self.seconds, self._now = False, True, [], {}
        for name in self.SOLVE:
            self._wrap(solve, name, name)
        self._wrap(problem.OptimalControlProblem, "with_boundary", "with_boundary")
        self._wrap(ipopt.PackedSolver, "__call__", "packed call")
        self._wrap(ipopt.PackedSolver, "stats", "stats", caller="solve")

    def _wrap(self, owner, name, label, caller=None):
        inner = getattr(owner, name)

        def timed(*args, **kwargs):
            tic = time.perf_counter()
            out = inner(*args, **kwargs)
            if self.record and (caller is None or sys._getframe(1).f_code.co_name == caller):
                self._now[label] = self._now.get(label, 0.0) + time.perf_counter() - tic
            return out
        setattr(owner, name, timed)

    def around(self, step):
        """step wrapped: its pieces' seconds appended to `seconds`, IPOPT's own time (the
        figures' second entry) taken off the packed call."""
        def counted(i):
            if not self.active:
                return step(i)
            self._now, self.record = {}, True
            try:
                row = step(i)
            finally:
                self.record = False
            self._now["packed call"] -= row[1]
            self.seconds.append(self._now)
            return row
        return counted

    def print(self):
        print("\ndmoc raw C: the pieces outside IPOPT where they run (median us per re-solve)")
        total = 0.0
        for label in ("with_boundary",) + self.SOLVE[:3] + ("packed call", "stats") + self.SOLVE[3:]:
            us = float(np.median([s.get(label, 0.0) for s in self.seconds])) * 1e6
            total += us
            print(f"  {label:<16}{us:>8.1f}")
        print(f"  {'sum':<16}{total:>8.1f}")


def figures(st, wall):
    """[wall, IPOPT, functions, iterations, calls of each Function] of one re-solve from
    CasADi's nlpsol stats `st` and the call's wall seconds."""
    if not st["success"]:
        raise RuntimeError(st["return_status"])
    functions = sum(st["t_wall_" + k] for k in FUNCTIONS)
    return [wall, st["t_wall_total"], functions, st["iter_count"]] + [st["n_call_" + k] for k in FUNCTIONS]


def dmoc_method(name, rule, N, targets, options):
    """step(goal index) -> figures of dmoc's raw compiled re-solve with the IPOPT `options`,
    from the stats of the solver it keeps (which carry t_wall_total: `dmoc.optimal_control.solver.ipopt`
    has CasADi record it)."""
    from dmoc.optimal_control.solver import ipopt
    from dmoc.optimal_control.solver.solving import solve
    problem = peers.dmoc_problem(name, N, rule, targets[0])
    previous = solve(problem, jit=True, options=options)
    T = problem.transcription
    if ipopt.data_tolerances(T, previous.x / T.x_scale, jit=True):
        raise RuntimeError("the data raise the tolerances: the solver below would not be the one used")
    solver = ipopt.solver(T, {**ipopt.start_options(True), **options}, expand=False, reuse=True,
                          report=False, jit=True)[0]      # the kept solver of the warm re-solves

    def step(i):
        nonlocal previous
        tic = time.perf_counter()
        previous = solve(peers.moved(problem, name, targets[i]), guess=previous, jit=True, options=options)
        wall = time.perf_counter() - tic
        return figures(solver.stats(), wall)
    return step


def rockit_method(name, N, targets, options, status=False):
    """step(goal index) -> figures of rockit's compiled function re-solve with the IPOPT
    `options` over `peers_resolve.IPOPT`; with `status`, the call followed by the reading of
    its return status (``resolve.stats()``, within the timed call): the function returns
    IPOPT's last iterate whether or not it converged, so a loop that must know has to read
    it."""
    shared = dict(peers.IPOPT)
    peers.IPOPT.update(options)
    try:
        ocp, goal = peers.rockit_ocp(name, N, jit=True)
        sol = peers.rockit_solve(ocp, goal, targets[0])
    finally:
        peers.IPOPT.clear()
        peers.IPOPT.update(shared)
    opti = ocp._method.opti
    resolve = ocp.to_function("resolve", [goal, opti.x, opti.lam_g], [opti.x, opti.lam_g, opti.f])
    x, lam_g = sol.sol.sol.value(opti.x), sol.sol.sol.value(opti.lam_g)

    def step(i):
        nonlocal x, lam_g
        tic = time.perf_counter()
        x, lam_g, _ = resolve(targets[i], x, lam_g)
        if status and not resolve.stats()["success"]:
            raise RuntimeError("rockit's re-solve failed")
        wall = time.perf_counter() - tic
        return figures(resolve.stats(), wall)
    return step


def factor(text):
    """(entries in the factors INFOG(29), operations of one factorization's node
    eliminations RINFO(3)) of the last factorization in MUMPS's own report `text`."""
    entries = int(re.findall(r"INFOG \(29\) Number of entries in factors\s+=\s+(\d+)", text)[-1])
    flops = float(re.findall(r"Operations in node elimination\s+=\s+(\S+)", text)[-1].replace("D", "E"))
    return entries, flops


def structure(text):
    """{free variables, rows, nnz jac_g, nnz hess_l (triangle)} as IPOPT's journal `text`
    prints them."""
    def grab(label):
        return int(re.search(label + r"\.*:\s+(\d+)", text).group(1))
    return {"variables": grab("Total number of variables"), "rows": grab("Total number of equality constraints"),
            "jac": grab("Number of nonzeros in equality constraint Jacobian"),
            "hess": grab("Number of nonzeros in Lagrangian Hessian")}


def reported(resolve):
    """(IPOPT's journal, MUMPS's report on the standard output) of `resolve()`, a solve
    with the options of `REPORT` (the file named there)."""
    sys.stdout.flush()
    saved, out = os.dup(1), tempfile.TemporaryFile(mode="w+")
    os.dup2(out.fileno(), 1)
    try:
        resolve()
        gc.collect()            # the solvers dropped: MUMPS's farewell goes to the report too
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    out.seek(0)
    with open(REPORT["output_file"]) as file:
        return file.read(), out.read()


def kkt(name, rule, N, N_rockit, targets):
    """{method: structure, factor entries, operations} of one solve of the second goal each
    (dmoc's warm, rockit's cold: the structure of the KKT matrix is the same), with IPOPT's
    journal and MUMPS's report (evaluated by CasADi's virtual machine: the same
    matrices)."""
    from dmoc.optimal_control.solver.solving import solve
    out = {}
    problem = peers.dmoc_problem(name, N, rule, targets[0])
    previous = solve(problem)
    journal, report = reported(lambda: solve(peers.moved(problem, name, targets[1]), guess=previous,
                                             options=REPORT, reuse_solver=False))
    out["dmoc"] = {**structure(journal), "factor": factor(report)}

    def rockit():
        peers.IPOPT.update(REPORT)
        ocp, goal = peers.rockit_ocp(name, N_rockit)
        for key in REPORT:
            del peers.IPOPT[key]
        peers.rockit_solve(ocp, goal, targets[1])      # cold: the same matrices
    journal, report = reported(rockit)
    out["rockit"] = {**structure(journal), "factor": factor(report)}
    os.remove(REPORT["output_file"])
    return out


def packed_input(name, rule, N, targets, calls):
    """(median us of the packed IPOPT call with its input as a NumPy array (before) and
    through the packed Function's buffer (`dmoc.optimal_control.solver.ipopt.PackedSolver`, now), the
    number of entries): `calls`
    alternating calls at the optimum of the second goal, from its own x and multipliers
    (0 iterations: the call's conversions stand out); the outputs of the two have the same
    bits (asserted)."""
    from dmoc._util.conversions import vector
    from dmoc.optimal_control.solver import ipopt
    from dmoc.optimal_control.solver.solving import solve
    problem = peers.moved(peers.dmoc_problem(name, N, rule, targets[0]), name, targets[1])
    T, D, R = problem.transcription, problem.transcription.x_scale, problem.transcription.g_scale
    optimum = solve(problem, jit=True, guess=solve(problem, jit=True))
    packed = ipopt.solver(T, ipopt.start_options(True), expand=False, reuse=True, report=False, jit=True)[0]
    inputs = {"x0": optimum.x / D, "p": T.p, "lam_x0": optimum.lam_x * D, "lam_g0": optimum.lam_g / R,
              "lbx": T.lbx / D, "ubx": T.ubx / D, "lbg": T.lbg * R, "ubg": T.ubg * R}

    def as_array():
        z = np.concatenate([inputs[k] for k in packed._inputs.blocks])
        return packed._outputs.split(vector(packed._function.function(z)))
    seconds = ([], [])
    for i in range(calls):
        outs = []
        for k, call in enumerate((as_array, lambda: packed(**inputs))):
            tic = time.perf_counter()
            outs.append(call())
            seconds[k].append(time.perf_counter() - tic)
        if i == 0:
            assert all(np.array_equal(outs[0][k].view(np.int64), outs[1][k].view(np.int64)) for k in outs[0])
    return [float(np.median(t)) * 1e6 for t in seconds], sum(v.size for v in inputs.values())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=40, help="cycles over the goals (default 40)")
    parser.add_argument("--problem", choices=PROBLEMS, default="disk")
    parser.add_argument("--rotate", action="store_true",
                        help="turn the order of the methods goal by goal (default: the order listed, "
                             "so that dmoc's first row follows rockit's)")
    parser.add_argument("--blocks", action="store_true",
                        help="each method re-solves the whole cycle of goals in a row, as a user's "
                             "loop does, the methods in turn, their order reversed cycle by cycle "
                             "(default: the methods in turn goal by goal)")
    parser.add_argument("--pieces", action="store_true",
                        help="also time the pieces of dmoc's re-solve outside IPOPT where they run")
    args = parser.parse_args(argv)
    pieces = Pieces() if args.pieces else None
    name, rule, N, N_rockit = PROBLEMS[args.problem]
    targets = peers.goals(name, 5)
    print(f"{name}: dmoc {rule} N = {N}, rockit N = {N_rockit}; load average "
          f"{'%.2f %.2f %.2f' % os.getloadavg()}")
    methods = {"dmoc raw C": dmoc_method(name, rule, N, targets, {}),
               "dmoc raw C, KKT residuals (no fast steps)": dmoc_method(
                   name, rule, N, targets, {"fast_step_computation": "no"}),
               "dmoc raw C, fixed variables' multipliers by IPOPT": dmoc_method(
                   name, rule, N, targets, {"fixed_variable_treatment": "make_parameter"}),
               "rockit function C": rockit_method(name, N_rockit, targets, {}),
               "rockit function C, fast steps": rockit_method(
                   name, N_rockit, targets, {"fast_step_computation": "yes"}),
               "rockit function C, its status read": rockit_method(name, N_rockit, targets, {}, status=True)}
    if pieces:
        methods["dmoc raw C"] = pieces.around(methods["dmoc raw C"])
    order = list(range(1, len(targets))) + [0]
    rows = {m: [] for m in methods}
    names, turn = list(methods), 0
    for cycle in range(args.repeat):
        if args.blocks:         # a method's re-solve follows its own, but for a block's first
            for method in names if cycle % 2 == 0 else names[::-1]:
                rows[method].extend(methods[method](i) for i in order)
            continue
        for i in order:
            # with --rotate the method that goes first turns; each method still follows the
            # same one (the cyclic order is kept): dmoc's first row follows rockit's last
            first = turn % len(names) if args.rotate else 0
            for method in names[first:] + names[:first]:
                rows[method].append(methods[method](i))
            turn += 1
    still = {m: [] for m in methods}          # a re-solve at the goal just solved: 0 iterations
    if pieces:
        pieces.active = False
    for _ in range(args.repeat):
        for method, step in methods.items():
            still[method].append(step(0))
    print(f"\n{'method':<54}{'ms':>7}{'IPOPT':>7}{'fun':>6}{'rest':>7}{'out':>6}{'it':>5}"
          f"{'rest/it':>8}{'0-it ms':>8}{'0-it IPOPT':>11}   calls f, g, grad_f, jac_g, hess_l")
    for method in methods:
        a, z = np.array(rows[method]), np.array(still[method])
        wall, ipopt, fun = (np.median(a[:, k]) * 1e3 for k in range(3))
        rest, out, it = np.median(a[:, 1] - a[:, 2]) * 1e3, np.median(a[:, 0] - a[:, 1]) * 1e3, np.median(a[:, 3])
        calls = ", ".join(f"{c:.2f}" for c in a[:, 4:].mean(axis=0))
        print(f"{method:<54}{wall:>7.3f}{ipopt:>7.3f}{fun:>6.3f}{rest:>7.3f}{out:>6.3f}{it:>5.1f}"
              f"{rest / it:>8.3f}{np.median(z[:, 0]) * 1e3:>8.3f}{np.median(z[:, 1]) * 1e3:>11.3f}   {calls}"
              f" (0 it: {int(np.median(z[:, 3]))})")
    if pieces:
        pieces.print()
    print("\nthe KKT matrix and MUMPS's factors (IPOPT's journal, MUMPS's report):")
    for method, s in kkt(name, rule, N, N_rockit, targets).items():
        print(f"  {method:<7} variables {s['variables']}, rows {s['rows']}, KKT rows {s['variables'] + s['rows']}, "
              f"nnz jac_g {s['jac']}, hess_l {s['hess']}; entries in the factors {s['factor'][0]}, "
              f"operations per factorization {s['factor'][1]:.3g}")
    (array, buffered), entries = packed_input(name, rule, N, targets, 20 * args.repeat)
    print(f"\ndmoc's packed IPOPT call at an optimum (0 iterations), its input of {entries} entries as a "
          f"NumPy array (before) {array:.1f} us, through the Function's buffer (now) {buffered:.1f} us: "
          f"{buffered / array:.3f}, {array - buffered:.1f} us less; the same bits")
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
