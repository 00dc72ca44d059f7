"""The IPOPT solver of a DMOC problem (consumer 2, its solver half): dmoc's default IPOPT
options, the tolerances the data demand, and the solvers, created once per problem
structure and options and kept in a bounded cache, each with its own journal when the
linear-solver report is asked for; what IPOPT's statistics say about a solve.
"""

import weakref

import casadi as ca
import numpy as np

from ..._util import typed_ops
from ..._util.cache import BoundedCache
from ..._util.layout import Layout
from ..._util.numeric import Evaluator
from ...errors import InputError
from .linear_solver import JOURNAL_LEVEL, new_journal, remove_journal
from ..nlp.evaluation import nlp_functions
from .fixed_multipliers import FixedMultipliers
from .violation import largest_violation, on_bound

# bound_relax_factor 0: IPOPT keeps the bounds as given while iterating (its default relaxes
# them by 1e-8), so the optimum meets both the bounds and the rows. With a relaxation,
# honor_original_bounds moves x back onto an active bound after the last iterate and leaves
# the rows violated by up to about the relaxation, above constr_viol_tol
# (docs/verification.md). honor_original_bounds stays for a user's own bound_relax_factor.
# warm_start_init_point (not a default: `optimize` sets it per start) "yes" when the
# multipliers of a previous optimum of the same structure are passed in, "no" otherwise,
# so that IPOPT estimates them by least squares at the start point, which takes fewer
# iterations than zero multipliers from a guess of another grid (tests/optimize/test_resolve.py).
# mumps_permuting_scaling 0, mumps_pivot_order 0: MUMPS's analysis with AMD and without
# the MC64 matching. The DMOC KKT matrices are banded, so AMD orders them well and MC64
# and the automatic ordering cost more than the factorizations themselves, for the same
# iterations.
# mumps_pivtol 1e-4 (IPOPT's 1e-6): pivots of at least 1e-4 of their column's largest entry,
# accurate for IPOPT's residual ratio without iterative refinement at every N (with 1e-6 the
# disk, lobatto4, grew as N^1.41: 11 ... 60 back-solves at N = 100 ... 800; peers.py nlp);
# mumps_mem_percent 100 (IPOPT's 1000: page-faulted anew at each factorization, docs/stages/optimize.md).
# fixed_variable_treatment make_parameter_nodual: IPOPT takes the fixed entries of x (the
# given boundary data) out of its problem, as with its default make_parameter, but does not
# compute their bound multipliers at every iteration (a gradient of f each); they are
# made when a result's lam_x is first read (`FixedMultipliers`), the same bits.
DEFAULT_IPOPT_OPTIONS = {"tol": 1e-10, "constr_viol_tol": 1e-10, "print_level": 0, "sb": "yes",
                         "max_iter": 1000, "bound_relax_factor": 0.0, "honor_original_bounds": "yes",
                         "mumps_permuting_scaling": 0, "mumps_pivot_order": 0, "mumps_pivtol": 1e-4,
                         "mumps_mem_percent": 100, "fixed_variable_treatment": "make_parameter_nodual"}
# per start (`start_options`): warm_start_init_point as above; and for a warm start
# fast_step_computation "yes": IPOPT takes the solution of each KKT system as MUMPS returns
# it, without computing its residual (nor refining it). On warm re-solves and MPC steps of
# 10 problems (benchmarks/warm_options.py; bounds active, free final time, holonomic,
# degenerate, parameters among them) the same iterations as IPOPT's default, x within
# 7e-14 relative, in less of IPOPT's time; the lane change, whose iterations move with
# a change of its start in the 14th digit, took other iterations, in both directions.
# MUMPS keeps its scaling of the KKT matrices (mumps_scaling 77): without it
# (warm_options.py --arm '{"mumps_scaling": 0}') the LC circuit's re-solves at N = 100
# took 24 iterations instead of 17 and ended 5e-10 from a cold solve's optimum. A first
# solve keeps IPOPT's default (on the group: `group_solving.GUESS_OPTIONS`).
# The barrier starts at mu_init 1e-6 and the warm start moves x, the slacks and the bound
# multipliers off their bounds by at most 1e-8 (IPOPT's defaults 0.1 and 1e-3): with those
# defaults IPOPT first leaves the active bounds and rows of the optimum it starts from, and
# a re-solve of a bounded problem from its own optimum took as long as a cold solve (the
# truck backing a trailer into a bay, tests/optimize/hard_problems.py: 71 and 165
# iterations; the lane change example 182 and 258); with these 2 and 3 (issue 40,
# benchmarks/warm_options.py, docs/performance.md "Hard problems and warm starts with
# active bounds").
WARM_START_OPTIONS = {"warm_start_init_point": "yes", "fast_step_computation": "yes",
                      "mu_init": 1e-6, "warm_start_bound_push": 1e-8, "warm_start_bound_frac": 1e-8,
                      "warm_start_slack_bound_push": 1e-8, "warm_start_slack_bound_frac": 1e-8,
                      "warm_start_mult_bound_push": 1e-8}
COLD_START_OPTIONS = {"warm_start_init_point": "no"}


def start_options(warm):
    """The IPOPT options of a warm (True: x and multipliers of a previous optimum of the
    same structure) or cold start, `WARM_START_OPTIONS` or `COLD_START_OPTIONS`."""
    return WARM_START_OPTIONS if warm else COLD_START_OPTIONS


_SOLVERS = BoundedCache(16, "solvers")    # keyed by (structure, options, report, expand, jit): two per structure
_OPTION_SETS = BoundedCache(64, "solver_options")   # keyed by (defaults, options' reprs, report): `_nlpsol_options`
_ROW_SUMS = BoundedCache(16, "row_sums")  # keyed by (transcription.structure, jit): `_largest_row_sum`
_EPS = np.finfo(float).eps


def data_tolerances(transcription, x0, jit=False):
    """{"tol", "constr_viol_tol"} raised above DEFAULT_IPOPT_OPTIONS' 1e-10 to the rounding
    floor of the rows where the data demand it, else {}. The floor of row i is
    eps * sum_j |dg_i/dx_j| |x_j| at the start point x0 (scaled, as IPOPT sees it) in
    absolute coordinates (q, not q - q_ref): the rows difference configurations over h,
    so far from the origin (|q| ~ 1e6 m at h = 0.04 s: 1e-8) no iterate can bring them
    below it. Rounded up to a power of 2, so that nearby start points share one solver (the
    options are its key). The Jacobian is the solver's (compiled with `jit`, the same
    numbers)."""
    T = transcription
    largest = _ROW_SUMS.get((T.structure, jit), lambda: Evaluator(_largest_row_sum(T, jit)))
    floor = _EPS * float(largest.vector(np.concatenate([x0, T.p]))[0])
    if not floor > DEFAULT_IPOPT_OPTIONS["constr_viol_tol"]:       # also when NaN
        return {}
    floor = float(2.0 ** np.ceil(np.log2(floor)))
    return {"tol": floor, "constr_viol_tol": floor}


def _largest_row_sum(transcription, jit):
    """Function ``[x; p] -> max_i sum_j |dg_i/dx_j(x, p)| |x_abs_j|`` (0 without rows),
    x_abs the x of absolute configurations: its block q plus p's q_ref at every knot, the
    sum `Transcription.configurations` forms (x + 0 elsewhere: the same absolute values).
    One call of one stacked argument from Python instead of a call per operation,
    evaluated through its buffer (`data_tolerances` wraps it in an `Evaluator`)."""
    separable, lay = transcription.separable, transcription.x_layout
    n_x, q = separable.n_x, lay.slice("q")
    z = ca.MX.sym("z", n_x + separable.n_p)
    x, p = z[:n_x], z[n_x:]
    q_ref = p[transcription.p_layout.slice("q_ref")]
    shift = ca.vertcat(ca.MX(q.start, 1), ca.repmat(q_ref, lay.blocks["q"][2], 1), ca.MX(n_x - q.stop, 1))
    jacobian = nlp_functions(separable, jit=jit)["nlp_jac_g"](x, p)[1]
    rows = ca.mtimes(typed_ops.fabs(jacobian), typed_ops.fabs(typed_ops.plus(x, shift)))
    return ca.Function("largest_row_sum", [z], [ca.mmax(rows) if separable.n_g else ca.MX(0)],
                       ["z"], ["largest"])


def solver(transcription, options, *, expand, reuse, report, jit=False):
    """(the `PackedSolver` of `transcription` with the IPOPT `options`, whether it came
    from the cache, the path of its journal or None); `expand`, `reuse`, `report` and
    `jit` are `optimize`'s `expand`, `reuse_solver`, `linear_solver_report` and `jit`."""
    if report and "output_file" in options:
        raise InputError("`linear_solver_report` writes IPOPT's journal to a file "
                         "of its own; leave out `options` 'output_file' or the report.")
    # the options' reprs stand for their values, as in the solvers' key
    merged, opts, key = _OPTION_SETS.get(
        (tuple(DEFAULT_IPOPT_OPTIONS.items()), tuple((k, repr(v)) for k, v in options.items()), report),
        lambda: _nlpsol_options(options, report))
    built = []

    def build():
        """(a new solver, the path of its own journal or None, removed with the solver)."""
        built.append(True)
        journal = new_journal() if report else None
        cache = nlp_functions(transcription.separable, expand=expand, jit=jit)
        nodual = str(merged.get("fixed_variable_treatment")).lower() == "make_parameter_nodual"
        try:
            made = ca.nlpsol("dmoc", "ipopt", transcription.nlp,
                             {**opts, "cache": cache, **({"ipopt.output_file": journal} if report else {})})
        except RuntimeError as err:
            culprit = _rejected_option(options)
            if culprit is None and "option" not in str(err).lower():
                raise
            which = (f"`options` entry {culprit!r} = {options[culprit]!r}" if culprit is not None
                     else "`options`")
            raise InputError(f"{which} was rejected by CasADi/IPOPT (see IPOPT's message above "
                             f"for the allowed values).\n{err}") from None
        if journal:     # a solver dropped (reuse_solver=False, or evicted) takes its journal along
            weakref.finalize(made, remove_journal, journal).atexit = False
        return PackedSolver(made, transcription, FixedMultipliers(cache) if nodual else None), journal

    # with `jit`, `expand` changes nothing (`nlp_functions`): one solver for both
    solver, journal = build() if not reuse else _SOLVERS.get(
        (transcription.structure, key, report, expand and not jit, jit), build)
    return solver, reuse and not built, journal


def _nlpsol_options(options, report):
    """(the IPOPT `options` over DEFAULT_IPOPT_OPTIONS, the nlpsol options they make,
    their key in the solver cache: the repr of the sorted nlpsol options). Kept per set of
    defaults, `options` and `report` (`_OPTION_SETS`): making them and their key took
    a measurable part of a warm re-solve (benchmarks/peers.py resolve)."""
    merged = {**DEFAULT_IPOPT_OPTIONS, **options}
    if report:
        merged["file_print_level"] = JOURNAL_LEVEL
    # no_nlp_grad: the multipliers of p (the fixed step h) are not wanted, and the
    # gradient function CasADi would generate for them is most of a solver's build.
    # CasADi's own "expand" stays off: the cache holds all five Functions IPOPT calls, in
    # the form `expand` and `jit` ask for (`nlp_functions`), and expanding the unused MX
    # oracle besides cost 4-9 ms per build at N = 31-100. record_time: CasADi's wall time of
    # the nlpsol call itself (stats t_wall_total, `ipopt_time`), without the packed call's
    # conversions, measured as rockit's re-solves are (benchmarks/peers.py).
    opts = {"print_time": False, "error_on_fail": False, "no_nlp_grad": True,
            "calc_lam_p": False, "record_time": True, **{"ipopt." + k: v for k, v in merged.items()}}
    return merged, opts, repr(sorted(opts.items()))


class PackedSolver:
    """An IPOPT nlpsol called on NumPy vectors through one stacked input and one stacked
    output, read and written in place through the packed Function's buffer
    (`dmoc._util.numeric.Evaluator.vector`, one buffer per thread): no conversion to or
    from ``casadi.DM`` at all, the same floats in and out, in a small part of the time
    of an ordinary CasADi call on a list of floats (benchmarks/peers.py resolve). The one
    input and one output also carry what the result needs of x and the multipliers, so
    that `solve` forms no vector of them.

    Parameters
    ----------
    nlpsol : casadi.Function
        The IPOPT solver of `transcription`'s NLP.
    transcription : Transcription
        Gives the sizes n_x, n_g and n_p of x, g and p, and the scales x_scale and g_scale
        (fixed with the NLP: the terms' Functions, hence `structure`, hold them).
    fixed_multipliers : FixedMultipliers or None
        Given when IPOPT leaves the bound multipliers of fixed entries (lbx == ubx) zero
        (``fixed_variable_treatment`` "make_parameter_nodual"), to compute them after the
        solve as "make_parameter" gives them.

    Attributes
    ----------
    nlpsol : casadi.Function
        The solver itself.
    fixed_multipliers : FixedMultipliers or None
        As given.
    """

    def __init__(self, nlpsol, transcription, fixed_multipliers=None):
        n_x, n_g, n_p = (transcription.x_layout.size, transcription.g_layout.size,
                         transcription.p_layout.size)
        self.nlpsol, self.fixed_multipliers = nlpsol, fixed_multipliers
        self._inputs = Layout([("x0", n_x), ("p", n_p), ("lam_x0", n_x), ("lam_g0", n_g),
                               ("lbx", n_x), ("ubx", n_x), ("lbg", n_g), ("ubg", n_g)])
        self._outputs = Layout([("x", n_x), ("f", 1), ("g", n_g), ("lam_x", n_x), ("lam_g", n_g),
                                ("on_bound", 1), ("largest", 1), ("row", 1), ("result_x", n_x),
                                ("result_lam_x", n_x), ("result_lam_g", n_g), ("x_norm1", 1)])
        z = ca.MX.sym("z", self._inputs.size)
        inputs = self._inputs.split(z)
        sol = packed_outputs(transcription, nlpsol(**inputs), inputs)
        self._function = Evaluator(ca.Function("ipopt_packed", [z], [self._outputs.join(sol)], ["z"], ["sol"]))

    def __call__(self, **inputs):
        """{"x", "f", "g", "lam_x", "lam_g", "on_bound", "largest", "row", "result_x",
        "result_lam_x", "result_lam_g", "x_norm1"}: 1-d arrays (on_bound, largest, row
        and x_norm1 of shape (1,)) of the solve from the `inputs` of nlpsol (x0, p,
        lam_x0, lam_g0, lbx, ubx, lbg, ubg; 1-d arrays, the scaled NLP's): nlpsol's
        outputs, the number of entries of x with lbx < ubx on a bound
        (`violation.on_bound`), the largest violation of the unscaled rows at g and its
        first row (`violation.largest_violation`; 0 and 0 without rows), the result's x,
        lam_x and lam_g in the system's units (``x_scale * x``, ``lam_x / x_scale``,
        ``g_scale * lam_g``), and the 1-norm of result_x: inf or NaN when an entry is
        (or the sum overflows)."""
        z = np.concatenate([inputs[name] for name in self._inputs.blocks])
        return self._outputs.split(self._function.vector(z))

    def stats(self):
        """IPOPT's statistics of the last solve: the packed Function's, which are
        those of the nlpsol it calls (the nlpsol's own `stats()` are of its direct calls)."""
        return self._function.stats()


def packed_outputs(transcription, sol, inputs):
    """`sol` (MX: nlpsol's outputs x, f, g, lam_x, lam_g of `transcription`'s scaled NLP)
    with what a result needs of them (`PackedSolver.__call__`): on_bound, the largest
    violation of the unscaled rows and its row, result_x, result_lam_x, result_lam_g and
    x_norm1; `inputs` gives lbx, ubx, lbg and ubg (MX)."""
    sol = dict(sol)
    sol["on_bound"] = on_bound(sol["x"], inputs["lbx"], inputs["ubx"])
    # the result's vectors unscaled (as MX constants, each product through `typed_ops`: the
    # bits of D * x; none for unit scales, the group's), and the 1-norm of x, finite when x is
    D, R = (None if (v == 1).all() else ca.MX(ca.DM(v)) for v in (transcription.x_scale, transcription.g_scale))
    sol["result_x"], sol["result_lam_x"] = ((sol["x"], sol["lam_x"]) if D is None else
                                            (typed_ops.times(D, sol["x"]), typed_ops.divide(sol["lam_x"], D)))
    sol["result_lam_g"] = sol["lam_g"] if R is None else typed_ops.times(R, sol["lam_g"])
    sol["x_norm1"] = ca.sum1(typed_ops.fabs(sol["result_x"]))
    n_g = transcription.g_layout.size
    if n_g:         # the rows unscaled: g / g_scale, the bounds likewise (powers of 2: exact)
        sol["largest"], sol["row"] = largest_violation(n_g)(*(
            v if R is None else typed_ops.divide(v, R) for v in (sol["g"], inputs["lbg"], inputs["ubg"])))
    else:
        sol["largest"] = sol["row"] = ca.MX(0)
    return sol


def _rejected_option(options):
    """The first of the user's IPOPT `options` that IPOPT refuses on its own (tried on a
    one-variable NLP), or None."""
    x = ca.SX.sym("x")
    for key, value in options.items():
        try:
            ca.nlpsol("probe", "ipopt", {"x": x, "f": x ** 2},
                      {"print_time": False, "ipopt." + key: value, "ipopt.print_level": 0,
                       "ipopt.sb": "yes"})
        except RuntimeError:
            return key
    return None


def iteration_count(st):
    """IPOPT's iteration count of this solve: 0 when it stopped before iterating (e.g.
    Invalid_Option), where CasADi's `iter_count` is left uninitialized."""
    count = st.get("iter_count", 0) if st.get("iterations") else 0
    return count if isinstance(count, int) and count >= 0 else 0


# the wall times of the five Functions IPOPT calls (`evaluation.nlp_functions`), in the
# order of IPOPT's statistics (sorted), so that their sum has the bits of summing them there
_EVALUATION_TIMES = tuple(sorted("t_wall_nlp_" + name for name in ("f", "g", "grad_f", "jac_g", "hess_l")))


def linear_algebra(st):
    """What IPOPT's KKT solves cost and needed: seconds outside function evaluations, and
    the iterations whose KKT matrix had the wrong inertia, so that IPOPT added delta_w I to
    the Hessian block (its largest delta_w)."""
    delta = st.get("iterations", {}).get("regularization_size", [])
    evaluations = sum(st.get(key, 0.0) for key in _EVALUATION_TIMES)
    return {"function_time": evaluations, "regularized_iterations": sum(d > 0 for d in delta),
            "max_regularization": max(delta, default=0.0)}
