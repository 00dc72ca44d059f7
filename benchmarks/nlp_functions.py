"""Benchmark: the five Functions IPOPT calls in a DMOC solve (nlp_f, nlp_g, nlp_grad_f,
nlp_jac_g, nlp_hess_l), per call, in CasADi's virtual machine on the MX graph of mapped
terms ("VM", the default), expanded to flat SX Functions ("SX", ``expand=True``) and
compiled to C ("C", ``jit=True``; `dmoc.optimal_control.nlp.evaluation`), at the problems
and N of the rockit comparison (`peers_resolve.py`: the least N reaching 1e-6 of J*), with
the sizes IPOPT's KKT matrix is made of (nonzeros of jac_g and of the Hessian's upper
triangle), the time to expand the five Functions, to compile the library and to load it
from the cache folder (docs/performance.md, "Re-solves against rockit").

Each Function is evaluated `--calls` times inside one call of its serial ``map`` (no Python
between the calls, as in IPOPT) at the optimum (x) and random multipliers; VM, SX and C
alternate `--repeat` times in one process, the least time per call kept. Run with a python
that has rockit (the peers' environment) to add rockit's own five Functions (its expanded
SX NLP, taken out of its ``ocp.to_function`` solver) for the problems' rockit N.

    python benchmarks/nlp_functions.py [--calls 200] [--repeat 7]
    PYTHONPATH=. /work/venv-peers/bin/python benchmarks/nlp_functions.py     # with rockit
"""

import argparse
import os
import platform
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import dmoc  # noqa: E402
from dmoc.optimal_control.nlp import evaluation  # noqa: E402
from dmoc.optimal_control.solver.solving import solve  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peers_resolve import GOAL, dmoc_problem  # noqa: E402

NAMES = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
# the least N with |J_N - J*| / J* <= 1e-6 found by peers_resolve.py (docs/performance.md)
CASES = (("rolling disk", "lobatto3", 31), ("rolling disk", "lobatto4", 11),
         ("knife edge", "lobatto3", 28), ("knife edge", "lobatto4", 14))
ROCKIT_N = {"rolling disk": 42, "knife edge": 62}


def per_call(functions, arguments, calls, repeat):
    """{label: least seconds per call} of each Function in `functions` ({label: Function},
    the same inputs), evaluated `calls` times in one serial map, alternating, `repeat`
    times."""
    mapped = {label: f.map(calls, "serial") for label, f in functions.items()}
    best = dict.fromkeys(functions, np.inf)
    for _ in range(repeat):
        for label, f in mapped.items():
            tic = time.perf_counter()
            f(*arguments)
            best[label] = min(best[label], (time.perf_counter() - tic) / calls)
    return best


def arguments(name, x, p, n_g, rng):
    """The inputs of Function `name` at x, p (multipliers random)."""
    return (x, p, 1.0, rng.standard_normal(n_g)) if name == "nlp_hess_l" else (x, p)


def sizes(functions):
    """(nnz of jac_g, nnz of the Hessian's upper triangle) of a dict of the five Functions."""
    return functions["nlp_jac_g"].sparsity_out(1).nnz(), functions["nlp_hess_l"].sparsity_out(0).nnz()


def dmoc_rows(calls, repeat, rng):
    """Print per problem and rule the five Functions' VM and C times per call."""
    with tempfile.TemporaryDirectory() as folder:        # compile into an empty cache folder
        os.environ["DMOC_CACHE_DIR"] = folder
        for name, rule, N in CASES:
            problem = dmoc_problem(name, N, rule, GOAL[name])
            T = problem.transcription
            x = solve(problem).x / T.x_scale
            vm = T.separable.functions()
            tic = time.perf_counter()
            flat = evaluation.nlp_functions(T.separable, expand=True)
            expand_s = time.perf_counter() - tic
            dmoc.clear_caches("compiled_nlps")
            tic = time.perf_counter()
            compiled = evaluation.nlp_functions(T.separable, jit=True)
            compile_s = time.perf_counter() - tic
            dmoc.clear_caches("compiled_nlps")
            tic = time.perf_counter()
            evaluation.nlp_functions(T.separable, jit=True)
            load_s = time.perf_counter() - tic
            jac, hess = sizes(vm)
            print(f"\n{name}, {rule}, N = {N}: x {T.x_layout.size}, g {T.g_layout.size}, nnz jac_g "
                  f"{jac}, nnz triu hess_l {hess}; expand {expand_s * 1e3:.1f} ms, compile "
                  f"{compile_s:.2f} s, load {load_s * 1e3:.1f} ms")
            print(f"  {'Function':<11}{'VM us':>9}{'SX us':>9}{'C us':>9}{'SX/VM':>7}{'C/VM':>7}"
                  f"{'SX instructions':>17}")
            total = dict.fromkeys(("VM", "SX", "C"), 0.0)
            for f in NAMES:
                t = per_call({"VM": vm[f], "SX": flat[f], "C": compiled[f]},
                             arguments(f, x, T.p, T.g_layout.size, rng), calls, repeat)
                total = {k: total[k] + t[k] for k in total}
                print(f"  {f:<11}" + "".join(f"{t[k] * 1e6:9.1f}" for k in total)
                      + f"{t['SX'] / t['VM']:7.2f}{t['C'] / t['VM']:7.2f}{flat[f].n_instructions():17d}")
            print(f"  {'sum':<11}" + "".join(f"{total[k] * 1e6:9.1f}" for k in total)
                  + f"{total['SX'] / total['VM']:7.2f}{total['C'] / total['VM']:7.2f}")


def rockit_rows(calls, repeat, rng):
    """Print rockit's five Functions' times per call at its N (when rockit is importable)."""
    try:
        from peers_resolve import rockit_ocp, rockit_solve
    except ImportError:
        return
    try:
        import rockit  # noqa: F401
    except ImportError:
        print("\n(rockit not importable here: its rows are skipped)")
        return
    for name, N in ROCKIT_N.items():
        ocp, goal = rockit_ocp(name, N)
        sol = rockit_solve(ocp, goal, GOAL[name])
        opti = ocp._method.opti
        resolve = ocp.to_function("resolve", [goal, opti.x, opti.lam_g], [opti.x])
        ipopt = next(f for f in resolve.find_functions() if f.class_name() == "IpoptInterface")
        functions = {f: ipopt.get_function(f) for f in NAMES}
        x, p = sol.sol.sol.value(opti.x), sol.sol.sol.value(opti.p)
        jac, hess = sizes(functions)
        print(f"\nrockit {name}, N = {N}: x {opti.nx}, g {opti.ng}, nnz jac_g {jac}, nnz triu "
              f"hess_l {hess}\n  {'Function':<11}{'SX us':>9}{'SX instructions':>17}")
        total = 0.0
        for f in NAMES:
            t = per_call({"SX": functions[f]}, arguments(f, x, p, opti.ng, rng), calls, repeat)["SX"]
            total += t
            print(f"  {f:<11}{t * 1e6:9.1f}{functions[f].n_instructions():17d}")
        print(f"  {'sum':<11}{total * 1e6:9.1f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=200, help="calls per timing (default 200)")
    parser.add_argument("--repeat", type=int, default=7, help="timings per Function (default 7)")
    args = parser.parse_args(argv)
    print(f"python {platform.python_version()}, casadi {ca.__version__}; {os.cpu_count()} cores; "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    rng = np.random.default_rng(0)
    dmoc_rows(args.calls, args.repeat, rng)
    rockit_rows(args.calls, args.repeat, rng)
    print(f"\nload average {'%.2f %.2f %.2f' % os.getloadavg()} at end")


if __name__ == "__main__":
    main()
