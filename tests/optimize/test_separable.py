"""The derivatives `dmoc.separable.SeparableNLP` assembles from its terms are exact.

Oracles, none taken from the code under test:
- for the DMOC problems: CasADi's own algorithmic differentiation of the problem's f and g
  (``Function.factory`` on the whole mapped MX graph: grad:f:x, jac:g:x and the upper
  triangle of the Hessian of sigma f + lam^T g), compared as dense arrays at random
  points, with the assembled sparsity patterns required to contain the oracle's;
- for hand-made terms: f, g, the gradient, the Jacobian and the Hessian of the Lagrangian
  written out in closed form below;
- for the NLP of a problem on SO(3) x R^n_x: its rows written out below (the residual and
  the group product mapped over the steps, cay^{-1} of the goal in NumPy, the end momentum,
  the path rows knot by knot) and CasADi's AD of the whole NLP.
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.optimal_control.nlp.gather_scatter import INDICES_PER_OPERATION
from dmoc.optimal_control.nlp.gather_scatter import window as separable_window
from dmoc.optimal_control.nlp.separable import SeparableNLP, Term, function_key, local_derivatives, term_cost
from dmoc.systems import knife_edge, lc_circuit, rolling_disk, spherical_pendulum

N = 4                                   # steps of every DMOC case
T = 1.2                                 # their duration (h = T / N = 0.3)
L0, C1, C2 = 0.8, 0.5, 1.5              # the LC circuit of tests/mechanics/test_degenerate.py
SPHERE_START = [np.sin(0.5), 0.0, -np.cos(0.5)]
SPHERE_GOAL = [0.0, np.sin(0.5), -np.cos(0.5)]

# --- the DMOC problems ---------------------------------------------------------------------

SYSTEMS = {
    "knife": {"system": knife_edge, "rules": ("midpoint", "trapezoid", "lobatto3"),
              "q_start": [0.0, 0.0, 0.0], "q_goal": [0.0, 1.0, 0.0],
              "free": {"q_goal": [0.0, 1.0, None], "v_start": [None, None, 0.0],
                       "v_goal": [None, None, 0.3]}},
    "disk": {"system": rolling_disk, "rules": ("midpoint", "trapezoid", "lobatto3"),
             "q_start": [0.0, 0.0, 0.0, 0.0], "q_goal": [1.0, 1.0, 0.5, np.pi / 2],
             "free": {"q_goal": [1.0, 1.0, None, np.pi / 2], "v_goal": [None, None, None, 0.0]}},
    # holonomic: the goal must leave z free, so its end is always partly free
    "sphere": {"system": spherical_pendulum, "rules": ("midpoint", "trapezoid", "lobatto3"),
               "q_start": SPHERE_START, "q_goal": [*SPHERE_GOAL[:2], None],
               "free": {"q_goal": [*SPHERE_GOAL[:2], None], "v_goal": [None, 0.1, None]}},
    # degenerate: only the midpoint rule gives a one-step map (tests/mechanics/test_degenerate.py)
    "lc": {"system": lambda: lc_circuit(L0, (C1, C2)), "rules": ("midpoint",),
           "q_start": [0.0, 0.0, 0.0], "q_goal": [1.0, C1 / (C1 + C2), C2 / (C1 + C2)],
           "free": {"q_goal": [1.0, None, None], "v_goal": [None, None, 0.0]}},
}


def _path(q, v, u):
    return ca.vertcat(q[0] ** 2 + ca.sin(q[-1]) * v[0] - 1, u[0] * q[1] - v[-1] ** 2)


def _terminal(q, v):
    return ca.cos(q[-1]) * ca.sumsqr(v) + q[0] ** 2 * q[1]


def _running(q, v, u):
    return ca.sumsqr(u) + ca.sin(q[0]) * v[1] ** 2 + q[1] * u[0] ** 2


def _options(system):
    """The optional data of a problem by name; "all" combines them."""
    spec = SYSTEMS[system]
    n = len(spec["q_start"])
    options = {"plain": {}, "free-time": {"duration": (0.5 * T, 2.0 * T)},
               "path": {"path_constraints": _path}, "terminal": {"terminal_cost": _terminal},
               "running": {"running_cost": _running}, "free-boundary": spec["free"],
               "velocity": {"velocity_bounds": ([-5.0] + [None] * (n - 1), [None] * (n - 1) + [5.0])}}
    options["all"] = {k: v for option in options.values() for k, v in option.items()}
    return options


def _lagrangian_cases():
    cases = []
    for system, spec in SYSTEMS.items():
        for rule in spec["rules"]:
            # every option on the knife edge; plain and all options on the others
            for option in _options(system) if system == "knife" else ("plain", "all"):
                for variant in ("+", "-"):
                    for momenta in ("substituted", "variables"):
                        cases.append(pytest.param(("lagrangian", system, rule, variant, momenta, option),
                                                  id=f"{system}-{rule}-{variant}-{momenta}-{option}"))
    cases += [pytest.param(("lagrangian", "knife", "lobatto4", variant, "substituted", "all"),
                           id=f"knife-lobatto4-{variant}-substituted-all") for variant in ("+", "-")]
    return cases


def _lagrangian_problem(system, rule, variant, momenta, option):
    spec = SYSTEMS[system]
    disc = dmoc.discretize(spec["system"](), T / N, rule)
    data = {"q_start": spec["q_start"], "q_goal": spec["q_goal"], **_options(system)[option]}
    return dmoc.OptimalControlProblem(disc, N, variant=variant, momenta=momenta, **data)


def _hamiltonian_knife():
    """The knife edge on an incline as H = |p|^2/2 + a x, forced (tests/discrete/test_hamiltonian.py)."""
    return dmoc.HamiltonianSystem(
        lambda q, p: ca.dot(p, p) / 2 + 0.3 * q[0], 3,
        constraints=lambda q: ca.horzcat(-ca.sin(q[2]), ca.cos(q[2]), 0),
        force=lambda q, p, u: ca.vertcat(u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), u[1]), n_u=2)


def _hamiltonian_sphere():
    """H = |p|^2/2 + g z on |q|^2 = 1 with a horizontal force (holonomic, Hamiltonian)."""
    return dmoc.HamiltonianSystem(
        lambda q, p: ca.dot(p, p) / 2 + 9.81 * q[2], 3, holonomic=lambda q: ca.dot(q, q) - 1,
        force=lambda q, p, u: ca.vertcat(u[0], u[1], 0), n_u=2)


def _hamiltonian_cases():
    cases = []
    for system in ("knife", "sphere"):
        for rule in ("midpoint", "symplectic-euler"):
            for variant in ("+", "-"):
                for momenta in ("substituted", "variables"):
                    for option in ("plain", "all"):
                        cases.append(pytest.param(("hamiltonian", system, rule, variant, momenta, option),
                                                  id=f"H-{system}-{rule}-{variant}-{momenta}-{option}"))
    # the discrete Legendre transform of a Lagrangian discretization
    cases += [pytest.param(("legendre", "knife", rule, variant, "substituted", "all"),
                           id=f"legendre-knife-{rule}-{variant}-substituted-all")
              for rule in ("midpoint", "trapezoid") for variant in ("+", "-")]
    return cases


def _hamiltonian_problem(kind, system, rule, variant, momenta, option):
    """(+) carries the momenta as variables whatever `momenta` says (q_{k+1} is its explicit
    end); (-) substitutes them where p_{k+1} is free of p_k."""
    if kind == "legendre":
        disc = dmoc.discrete_legendre(dmoc.discretize(knife_edge(), T / N, rule))
    else:
        make = {"knife": _hamiltonian_knife, "sphere": _hamiltonian_sphere}[system]
        disc = dmoc.discretize(make(), T / N, rule)
    spec = SYSTEMS[system]
    data = {"q_start": spec["q_start"], "q_goal": spec["q_goal"], **_options(system)[option]}
    return dmoc.OptimalControlProblem(disc, N, variant=variant, momenta=momenta, **data)


def _problem(case):
    if case[0] == "lagrangian":
        return _lagrangian_problem(*case[1:])
    return _hamiltonian_problem(*case)


def _oracle(problem):
    """grad f, jac g and triu hess(sigma f + lam^T g) by CasADi's AD of the whole NLP."""
    nlp = problem.nlp
    full = ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]], ["x", "p"], ["f", "g"])
    return {"f_g": full,
            "grad": full.factory("gf", ["x", "p"], ["grad:f:x"]),
            "jac": full.factory("j", ["x", "p"], ["jac:g:x"]),
            "hess": full.factory("h", ["x", "p", "lam:f", "lam:g"], ["triu:hess:gamma:x:x"],
                                 {"gamma": ["f", "g"]})}


def _random_point(problem, rng):
    """x (normal, scale 0.5; h, when free, in [0.2, 0.4]), lam_g (normal) and sigma."""
    x = rng.normal(scale=0.5, size=problem.x_layout.size)
    if problem.free_time:
        x[problem.x_layout.slice("h")] = rng.uniform(0.2, 0.4)
    return x, rng.normal(size=problem.g_layout.size), rng.uniform(0.5, 2.0)


def _dense(value):
    return np.array(ca.DM(value).full())


def _pattern(sparsity):
    """The structural nonzeros of `sparsity` as a dense boolean array."""
    return _dense(ca.DM(sparsity, 1.0)) != 0


def _assert_exact(actual, desired, what):
    desired = np.asarray(desired, float)
    atol = 1e-12 * max(1.0, np.abs(desired).max(initial=0.0))
    np.testing.assert_allclose(actual, desired, rtol=0, atol=atol, err_msg=what)


def _assert_covers(assembled, oracle, what):
    """Every structural nonzero of `oracle` is in `assembled`."""
    missing = np.argwhere(_pattern(oracle) & ~_pattern(assembled))
    assert missing.size == 0, f"{what}: oracle nonzeros missing from the pattern at {missing[:10].tolist()}"


def _assert_upper(sparsity, what):
    rows, cols = sparsity.get_triplet()
    assert np.all(np.asarray(rows) <= np.asarray(cols)), f"{what} has entries below the diagonal"


@pytest.mark.parametrize("case", _lagrangian_cases() + _hamiltonian_cases())
def test_assembled_derivatives_match_casadi_ad(case):
    """At a random point, the nlp_grad_f, nlp_jac_g and nlp_hess_l Functions handed to
    nlpsol equal CasADi's AD of the problem's f and g (values as dense arrays, to 1e-12
    of the largest entry), their sparsity patterns contain the oracle's, and the Hessian
    is stored as its upper triangle."""
    problem = _problem(case)
    oracle, assembled = _oracle(problem), problem.separable.derivatives()
    x, lam, sigma = _random_point(problem, np.random.default_rng(20240611))
    p = problem.p

    f, g = oracle["f_g"](x, p)
    f_a, grad_a = assembled["nlp_grad_f"](x, p)
    g_a, jac_a = assembled["nlp_jac_g"](x, p)
    hess_a = assembled["nlp_hess_l"](x, p, sigma, lam)
    _assert_exact(_dense(f_a), _dense(f), "f")
    _assert_exact(_dense(g_a), _dense(g), "g")

    grad, jac = _dense(oracle["grad"](x, p)), _dense(oracle["jac"](x, p))
    hess = _dense(oracle["hess"](x, p, sigma, lam))
    assert np.abs(jac).max() > 0 and np.abs(hess).max() > 0            # not vacuous
    _assert_exact(_dense(grad_a), grad, "grad f")
    _assert_exact(_dense(jac_a), jac, "jac g")
    _assert_exact(_dense(hess_a), hess, "triu hess L")

    _assert_covers(assembled["nlp_jac_g"].sparsity_out(1), oracle["jac"].sparsity_out(0), "jac g")
    _assert_covers(assembled["nlp_hess_l"].sparsity_out(0), oracle["hess"].sparsity_out(0), "hess L")
    _assert_upper(assembled["nlp_hess_l"].sparsity_out(0), "nlp_hess_l")
    assert assembled["nlp_grad_f"].sparsity_out(1).is_dense()


# --- hand-made terms -------------------------------------------------------------------------
#
# x = (x0, ..., x4), p = (p0, p1), five rows of g, three terms:
#   A (z in R^3, w in R^1) -> f = w z0 z1^2 + sin z2, g = (z0 z2 + w, z1^3), two instances
#     reading (x0, x1, x2; p0) and (x2, x3, x4; p1), filling rows (3, 0) and (1, 4):
#     windows overlapping in x2;
#   B (z in R^2, no w) -> f = exp(z0) z1, no g, two instances reading (x4, x0) (so its
#     local (0, 1) entry lands at (4, 0) below the diagonal) and (x1, x2);
#   C (z in R^2, w in R^1) -> f = 0, g = z0^2 - w z1, one instance reading (x3, x1; p1),
#     filling row 2.
# Hence f = p0 x0 x1^2 + sin x2 + p1 x2 x3^2 + sin x4 + exp(x4) x0 + exp(x1) x2 and
# g = (x1^3, x2 x4 + p1, x3^2 - p1 x1, x0 x2 + p0, x3^3).


def _hand_terms():
    z3, z2, w1, w0 = ca.SX.sym("z", 3), ca.SX.sym("z", 2), ca.SX.sym("w", 1), ca.SX.sym("w", 0)
    A = ca.Function("A", [z3, w1], [w1 * z3[0] * z3[1] ** 2 + ca.sin(z3[2]),
                                    ca.vertcat(z3[0] * z3[2] + w1, z3[1] ** 3)])
    B = ca.Function("B", [z2, w0], [ca.exp(z2[0]) * z2[1], ca.SX(0, 1)])
    C = ca.Function("C", [z2, w1], [ca.SX(0), z2[0] ** 2 - w1 * z2[1]])
    col = np.column_stack
    return [Term(A, col([[0, 1, 2], [2, 3, 4]]), col([[0], [1]]), col([[3, 0], [1, 4]])),
            Term(B, col([[4, 0], [1, 2]]), np.zeros((0, 2), int), np.zeros((0, 2), int)),
            Term(C, col([[3, 1]]), col([[1]]), col([[2]]))]


def _hand_values(x, p, sigma, lam):
    """f, g, grad f, jac g and the full symmetric Hessian of sigma f + lam^T g."""
    x0, x1, x2, x3, x4 = x
    p0, p1 = p
    f = p0 * x0 * x1 ** 2 + np.sin(x2) + p1 * x2 * x3 ** 2 + np.sin(x4) + np.exp(x4) * x0 + np.exp(x1) * x2
    g = np.array([x1 ** 3, x2 * x4 + p1, x3 ** 2 - p1 * x1, x0 * x2 + p0, x3 ** 3])
    grad = np.array([p0 * x1 ** 2 + np.exp(x4),
                     2 * p0 * x0 * x1 + np.exp(x1) * x2,
                     np.cos(x2) + p1 * x3 ** 2 + np.exp(x1),
                     2 * p1 * x2 * x3,
                     np.cos(x4) + np.exp(x4) * x0])
    jac = np.zeros((5, 5))
    jac[0, 1] = 3 * x1 ** 2
    jac[1, 2], jac[1, 4] = x4, x2
    jac[2, 1], jac[2, 3] = -p1, 2 * x3
    jac[3, 0], jac[3, 2] = x2, x0
    jac[4, 3] = 3 * x3 ** 2
    hf = np.zeros((5, 5))
    hf[0, 1] = 2 * p0 * x1
    hf[0, 4] = np.exp(x4)
    hf[1, 1] = 2 * p0 * x0 + np.exp(x1) * x2
    hf[1, 2] = np.exp(x1)
    hf[2, 2] = -np.sin(x2)
    hf[2, 3] = 2 * p1 * x3
    hf[3, 3] = 2 * p1 * x2
    hf[4, 4] = -np.sin(x4) + np.exp(x4) * x0
    hg = np.zeros((5, 5))
    hg[1, 1] = lam[0] * 6 * x1
    hg[2, 4] = lam[1]
    hg[3, 3] = lam[2] * 2 + lam[4] * 6 * x3
    hg[0, 2] = lam[3]
    upper = sigma * hf + hg
    hess = upper + np.triu(upper, 1).T
    return f, g, grad, jac, hess


def _hand_point():
    rng = np.random.default_rng(7)
    return rng.normal(scale=0.5, size=5), rng.normal(size=2), rng.uniform(0.5, 2.0), rng.normal(size=5)


def _evaluate(nlp, x, p, sigma, lam):
    d = nlp.derivatives()
    f, g = ca.Function("fg", [nlp.x, nlp.p], [nlp.f, nlp.g])(x, p)
    f_grad, grad = d["nlp_grad_f"](x, p)
    g_jac, jac = d["nlp_jac_g"](x, p)
    return {"f": f, "g": g, "f_grad": f_grad, "g_jac": g_jac, "grad": grad, "jac": jac,
            "hess": d["nlp_hess_l"](x, p, sigma, lam)}, d


def test_hand_made_terms_f_and_g():
    """f and g of the SeparableNLP (and the f, g outputs of nlp_grad_f and nlp_jac_g) are
    the hand-computed sums and rows: instances summed into f, g rows placed by g_index."""
    x, p, sigma, lam = _hand_point()
    nlp = SeparableNLP(5, 2, 5, _hand_terms())
    out, _ = _evaluate(nlp, x, p, sigma, lam)
    f, g = _hand_values(x, p, sigma, lam)[:2]
    for name, want in (("f", f), ("f_grad", f), ("g", g), ("g_jac", g)):
        _assert_exact(_dense(out[name]).ravel(), np.atleast_1d(want), name)


def test_hand_made_terms_derivatives():
    """Gradient, Jacobian and upper-triangle Hessian equal the closed forms: contributions
    of overlapping windows (x1, x2, x3 and the (1, 1), (3, 3) Hessian entries, shared by
    several terms and instances) are summed, p enters the derivatives, the empty-g term adds
    only to f, and an entry read as (4, 0) is stored at (0, 4)."""
    x, p, sigma, lam = _hand_point()
    nlp = SeparableNLP(5, 2, 5, _hand_terms())
    out, d = _evaluate(nlp, x, p, sigma, lam)
    _, _, grad, jac, hess = _hand_values(x, p, sigma, lam)
    _assert_exact(_dense(out["grad"]).ravel(), grad, "grad f")
    _assert_exact(_dense(out["jac"]), jac, "jac g")
    _assert_exact(_dense(out["hess"]), np.triu(hess), "triu hess L")
    _assert_upper(d["nlp_hess_l"].sparsity_out(0), "nlp_hess_l")
    assert np.all(_pattern(d["nlp_jac_g"].sparsity_out(1))[jac != 0])
    assert np.all(_pattern(d["nlp_hess_l"].sparsity_out(0))[np.triu(hess) != 0])


def test_hand_made_terms_at_several_points_and_sigma_zero():
    """The assembled Functions are functions of (x, p, sigma, lam), not of one point: with
    sigma = 0 only the constraints' curvature remains; at other x, p they still agree."""
    nlp = SeparableNLP(5, 2, 5, _hand_terms())
    rng = np.random.default_rng(11)
    for sigma in (0.0, 1.0, -0.7):
        x, p, lam = rng.normal(scale=0.5, size=5), rng.normal(size=2), rng.normal(size=5)
        out, _ = _evaluate(nlp, x, p, sigma, lam)
        _, _, grad, jac, hess = _hand_values(x, p, sigma, lam)
        _assert_exact(_dense(out["grad"]).ravel(), grad, "grad f")
        _assert_exact(_dense(out["jac"]), jac, "jac g")
        _assert_exact(_dense(out["hess"]), np.triu(hess), "triu hess L")


def test_single_term_without_shared_entries():
    """With no entry shared between instances (the permutation path of the assembly), one
    instance per column of x: f = sum_k x_k^2 y_k, g_k = x_k y_k - 1, rows in reverse."""
    z, w = ca.SX.sym("z", 2), ca.SX.sym("w", 0)
    term = ca.Function("t", [z, w], [z[0] ** 2 * z[1], z[0] * z[1] - 1])
    M = 3                                   # x = (x_0, y_0, x_1, y_1, x_2, y_2)
    nlp = SeparableNLP(2 * M, 0, M, [Term(term, np.arange(2 * M).reshape(M, 2).T,
                                          np.zeros((0, M), int), np.arange(M)[::-1].reshape(1, M))])
    rng = np.random.default_rng(3)
    x, sigma, lam = rng.normal(scale=0.5, size=2 * M), 1.3, rng.normal(size=M)
    out, _ = _evaluate(nlp, x, [], sigma, lam)
    xs, ys = x[0::2], x[1::2]
    grad = np.ravel(np.column_stack([2 * xs * ys, xs ** 2]))
    jac, hess = np.zeros((M, 2 * M)), np.zeros((2 * M, 2 * M))
    for k in range(M):
        row, mult = M - 1 - k, lam[M - 1 - k]
        jac[row, 2 * k], jac[row, 2 * k + 1] = ys[k], xs[k]
        hess[2 * k, 2 * k] = sigma * 2 * ys[k]
        hess[2 * k, 2 * k + 1] = sigma * 2 * xs[k] + mult
    _assert_exact(_dense(out["f"]).ravel(), [np.sum(xs ** 2 * ys)], "f")
    _assert_exact(_dense(out["g"]).ravel(), (xs * ys - 1)[::-1], "g")
    _assert_exact(_dense(out["grad"]).ravel(), grad, "grad f")
    _assert_exact(_dense(out["jac"]), jac, "jac g")
    _assert_exact(_dense(out["hess"]), hess, "triu hess L")


@pytest.mark.parametrize("g_index, n_g", [
    pytest.param([[0, 1]], 3, id="row-missing"),
    pytest.param([[0, 0]], 2, id="row-twice"),
    pytest.param([[0, 2]], 2, id="row-out-of-range"),
    pytest.param([[1, 2]], 3, id="row-0-missing"),
])
def test_g_index_must_fill_every_row_once(g_index, n_g):
    """A g_index that misses a row, fills one twice or points past n_g is refused."""
    z, w = ca.SX.sym("z", 1), ca.SX.sym("w", 0)
    term = Term(ca.Function("t", [z, w], [z[0], z[0] ** 2]), np.array([[0, 1]]),
                np.zeros((0, 2), int), np.array(g_index))
    with pytest.raises(ValueError, match="fill every row of g exactly once"):
        SeparableNLP(2, 0, n_g, [term])


@pytest.mark.parametrize("variant", ["+", "-"])
def test_configuration_dependent_mass_hamiltonian(variant):
    """H = (1 + q0^2) p0^2 / 2 + p1^2 / 2 couples q and p in the momentum rows, so the
    window of a substituted step reads q_k both as its q0 and as the previous step's q1:
    the Hessian at the shared entry (and at q_N in the goal rows) must count both (a
    review found it counted once; CasADi's AD is the oracle)."""
    system = dmoc.HamiltonianSystem(lambda q, p: 0.5 * (1 + q[0] ** 2) * p[0] ** 2 + 0.5 * p[1] ** 2,
                                    2, force=lambda q, p, u: u, n_u=2)
    problem = dmoc.OptimalControlProblem(dmoc.discretize(system, 0.3, "midpoint"), N,
                                         q_start=[0.0, 0.0], q_goal=[2.0, 0.5], variant=variant)
    oracle, assembled = _oracle(problem), problem.separable.derivatives()
    x, lam, sigma = _random_point(problem, np.random.default_rng(3))
    _assert_exact(_dense(assembled["nlp_hess_l"](x, problem.p, sigma, lam)),
                  _dense(oracle["hess"](x, problem.p, sigma, lam)), "Hessian")
    _assert_exact(_dense(assembled["nlp_jac_g"](x, problem.p)[1]), _dense(oracle["jac"](x, problem.p)),
                  "Jacobian")


def test_an_instance_reading_an_entry_twice_is_refused():
    z, w = ca.SX.sym("z", 2), ca.SX.sym("w", 0)
    term = Term(ca.Function("t", [z, w], [z[0] * z[1], ca.SX(0, 1)]), np.array([[0], [0]]),
                np.zeros((0, 1), int), np.zeros((0, 1), int))
    with pytest.raises(ValueError, match="reads an entry of x twice"):
        SeparableNLP(1, 0, 0, [term])


@pytest.mark.parametrize("M", [5, 3000])
@pytest.mark.parametrize("kind", ["blocks", "shared", "mixed", "irregular", "one instance",
                                  "adjacent steps"])
def test_window_equals_numpy_fancy_indexing(kind, M):
    """`window` slices what steps through a block and gathers the rest, or gathers all of
    a short window at once (M = 5; M = 3000 takes the slices): either way it is
    vector[index] (numpy fancy indexing is the oracle)."""
    rng = np.random.default_rng(7)
    size = 3 * M + 60
    vector = rng.normal(size=size)
    M = 1 if kind == "one instance" else M
    k = np.arange(M)
    block = 3 + np.arange(3)[:, None] + 3 * k            # 3 entries advancing by 3
    shared = np.full((2, M), size - 5) + np.arange(2)[:, None]  # the same 2 entries for every instance
    # "adjacent steps": consecutive entries at instance 0 that advance by different steps
    # (2 per instance, then 0): two runs, not one
    adjacent = np.vstack([2 * k, np.full(M, 1)])
    index = {"blocks": block, "shared": shared, "mixed": np.vstack([block, shared, block + 20]),
             "irregular": rng.integers(0, size, size=(4, M)), "one instance": np.vstack([block, shared]),
             "adjacent steps": adjacent}[kind]
    x = ca.MX.sym("x", size)
    got = np.array(ca.Function("w", [x], [separable_window(x, index)])(vector))
    np.testing.assert_array_equal(got, vector[index])


def _gathers(expression, x):
    """The number of GetNonzeros operations (slices and gathers of x) in `expression`."""
    f = ca.Function("w", [x], [expression])
    return sum(f.instruction_id(k) == ca.OP_GETNONZEROS for k in range(f.n_instructions()))


@pytest.mark.parametrize("M", [4, 200])
def test_window_takes_the_cheaper_of_one_gather_and_its_slices(M):
    """The documented rule of `window`: two runs of 3 rows that step through their blocks
    cost 2 * 2 + 1 = 5 operations as slices (a slice and a reshape each, one vertcat) and
    2 + 6 M / INDICES_PER_OPERATION as one gather and its reshape; the cheaper is built.
    M = 4 (24 entries): one gather, one GetNonzeros. M = 200 (1200 entries, cost 6): the two
    slices, one GetNonzeros each. Either way the value is vector[index] (numpy)."""
    k = np.arange(M)
    block = np.arange(3)[:, None] + 3 * k
    index = np.vstack([block, block + 3 * M + 7])
    gather_cost, slice_cost = 2 + index.size / INDICES_PER_OPERATION, 2 * 2 + 1
    assert (gather_cost <= slice_cost) == (M == 4)
    x = ca.MX.sym("x", index.max() + 5)
    built = separable_window(x, index)
    assert _gathers(built, x) == (1 if M == 4 else 2)
    vector = np.random.default_rng(8).normal(size=x.numel())
    np.testing.assert_array_equal(np.array(ca.Function("w", [x], [built])(vector)), vector[index])


def test_local_patterns_hold_only_the_entries_that_depend_on_z():
    """The gradient pattern of a term is structural, like its Jacobian's and Hessian's: a
    cost of z[0] alone has one gradient entry, and a term without cost (boundary rows)
    none, so that it adds nothing to the assembled gradient (a dense local gradient would
    carry every window entry through the assembly, twice the build time at N = 1000)."""
    z, w = ca.SX.sym("z", 3), ca.SX.sym("w", 1)
    cost = ca.Function("cost", [z, w], [w * z[0] ** 2, z[1] - z[2]])
    rows_only = ca.Function("rows_only", [z, w], [ca.SX(0), ca.vertcat(z[1] * z[2], z[0])])
    grad_rows, _ = local_derivatives(cost, function_key(cost))["grad_pattern"]
    np.testing.assert_array_equal(grad_rows, [0])
    local = local_derivatives(rows_only, function_key(rows_only))
    assert local["grad_pattern"][0].size == 0
    assert local["grad"] is None and term_cost(rows_only, function_key(rows_only)) is None
    hess_rows, hess_cols = local["hess_pattern"]          # lam_0 z1 z2: one upper entry
    np.testing.assert_array_equal(np.c_[hess_rows, hess_cols], [[1, 2]])


def _called(function):
    """The Functions that `function`'s MX graph calls (its OP_CALL instructions)."""
    return [function.instruction_MX(i).which_function() for i in range(function.n_instructions())
            if function.instruction_id(i) == ca.OP_CALL]


def test_f_calls_the_costs_alone():
    """A term Function computes its cost and its rows together; f calls each term's cost
    alone (a step term's rows are most of its operations, which f evaluated before at
    every call), nlp_grad_f and nlp_jac_g one Function per term for the value and its
    derivative, and a term without cost is not called by f. f and g are the closed
    forms: sum_k w z0_k^2 and the rows (z1 z2, z0) per instance."""
    z, w = ca.SX.sym("z", 3), ca.SX.sym("w", 1)
    cost = ca.Function("cost", [z, w], [w * z[0] ** 2, z[1] - z[2]])
    rows_only = ca.Function("rows_only", [z, w], [ca.SX(0), ca.vertcat(z[1] * z[2], z[0])])
    M = 4
    index = np.arange(3 * M).reshape(M, 3).T
    terms = [Term(cost, index, np.zeros((1, M), int), np.arange(M)[None, :]),
             Term(rows_only, index, np.zeros((1, M), int), M + np.arange(2 * M).reshape(M, 2).T)]
    nlp = SeparableNLP(3 * M, 1, 3 * M, terms)
    f, g = (ca.Function("fg", [nlp.x, nlp.p], [e]) for e in (nlp.f, nlp.g))
    calls = {name: [c.n_out() for c in _called(fun)] for name, fun in
             [("f", f), ("g", g), *[(k, nlp.derivatives()[k]) for k in ("nlp_grad_f", "nlp_jac_g")]]}
    assert calls == {"f": [1], "g": [2, 2], "nlp_grad_f": [2], "nlp_jac_g": [2, 2]}
    x, p = np.random.default_rng(3).normal(size=3 * M), np.array([0.7])
    Z = x.reshape(M, 3)
    np.testing.assert_allclose(float(f(x, p)), 0.7 * (Z[:, 0] ** 2).sum(), rtol=1e-15)
    expected = np.r_[Z[:, 1] - Z[:, 2], np.c_[Z[:, 1] * Z[:, 2], Z[:, 0]].ravel()]
    np.testing.assert_array_equal(np.array(g(x, p)).ravel(), expected)


@pytest.mark.parametrize("case", ["no rows", "rows without x"])
def test_derivatives_of_terms_without_jacobian_entries(case):
    """Terms that exist but give no Jacobian entry (no rows at all, or rows that do not
    depend on x) assemble an empty Jacobian, and the gradient and Hessian of their cost."""
    if case == "no rows":
        z, w = ca.SX.sym("z", 2), ca.SX.sym("w", 0)
        cost = ca.Function("cost", [z, w], [ca.sumsqr(z) * z[0], ca.SX(0, 1)])
        nlp = SeparableNLP(4, 0, 0, [Term(cost, np.array([[0, 2], [1, 3]]), np.zeros((0, 2), int),
                                          np.zeros((0, 2), int))])
        x, p = np.array([0.5, -1.0, 2.0, 0.25]), np.zeros(0)
    else:
        z, w = ca.SX.sym("z", 1), ca.SX.sym("w", 1)
        cost = ca.Function("cost", [z, w], [z[0] ** 2, w])           # g = p
        nlp = SeparableNLP(2, 1, 2, [Term(cost, np.array([[0, 1]]), np.array([[0, 0]]),
                                          np.array([[0, 1]]))])
        x, p = np.array([0.5, -1.0]), np.array([3.0])
    d = nlp.derivatives()
    f, grad = d["nlp_grad_f"](x, p)
    g, jac = d["nlp_jac_g"](x, p)
    hess = d["nlp_hess_l"](x, p, 1.0, np.ones(nlp.n_g))
    assert jac.nnz() == 0 and jac.shape == (nlp.n_g, nlp.n_x)
    oracle = ca.Function("o", [nlp.x, nlp.p], [ca.gradient(nlp.f, nlp.x), ca.triu(ca.hessian(nlp.f, nlp.x)[0])])
    grad_ref, hess_ref = oracle(x, p)
    np.testing.assert_allclose(np.array(grad).ravel(), np.array(grad_ref).ravel(), rtol=1e-14)
    np.testing.assert_allclose(np.array(ca.DM(hess)), np.array(ca.DM(hess_ref)), rtol=1e-14)


def test_a_problem_without_cost_builds_and_solves():
    """A zero running cost: no term adds gradient entries and the rows of the knife edge
    without cost add Hessian entries only through their multipliers; the NLP still builds
    and IPOPT finds a feasible point (any is optimal)."""
    disc = dmoc.discretize(knife_edge(), 0.1)
    problem = dmoc.OptimalControlProblem(disc, 20, q_start=[0.0, 0.0, 0.0], q_goal=[0.5, 0.2, 0.3],
                                         running_cost=lambda q, v, u: 0)
    result = dmoc.optimize(problem)
    assert result.success and result.cost == 0.0
    assert result.stats["max_violation"] < 1e-9


# --- the NLP of a problem on SO(3) x R^n_x -------------------------------------------------


def _group_problem(body):
    """N = 3 steps of the rolling sphere (constraint rows, the end impulse nu) or of the
    quadrotor past a cylinder (path rows at the knots)."""
    goal = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    if body == "sphere":
        disc = dmoc.discretize(dmoc.systems.chaplygin_sphere((1.0, 2.0, 2.5), 1.3, 0.7, torques=True), 0.4)
        return dmoc.GroupOptimalControlProblem(disc, 3, R_start=np.eye(3), R_goal=goal,
                                               x_start=[0.0, 0.0], x_goal=[1.0, 0.5])
    disc = dmoc.discretize(dmoc.systems.quadrotor(1.0, (0.5, 0.6, 0.9)), 0.4)
    return dmoc.GroupOptimalControlProblem(
        disc, 3, R_start=np.eye(3), R_goal=goal, x_start=[0.0, 0.0, 1.0], x_goal=[2.0, 0.0, 1.0],
        path_constraints=lambda R, x, u: ca.vertcat(0.09 - ca.sumsqr(x[:2] - [1.0, 0.0]), R[2, 2] * u[0] - 20))


def _cayley_inverse(F):
    """cay^{-1}(F) = 4 vee(F) / (1 + tr F), vee the vector of the skew part (written here)."""
    vee = 0.5 * np.array([F[2, 1] - F[1, 2], F[0, 2] - F[2, 0], F[1, 0] - F[0, 1]])
    return 4 * vee / (1 + np.trace(F))


def _group_rows(problem, T, x):
    """f and g of the group NLP at x, stated row by row here: the residual and the group
    product at every step (mapped over the steps), the goal, the end momentum and the path
    rows at every knot, in the blocks of `T.g_layout`."""
    N, R, h = problem.steps, problem.residual, problem.disc.h
    q, p, f, lam, u, nu = (T.x_layout.unpack(x, k) for k in ("q", "p", "f", "lam", "u", "nu"))
    dynamics = np.array(R.function.map(N)(q[:, :-1], p[:, :-1], f, p[:, 1:], lam, u, h))
    group = q[:, 1:] - np.array(R.reconstruction.map(N)(q[:, :-1], f))
    R_N, x_N = q[:9, -1].reshape(3, 3), q[9:, -1]
    A = np.array(problem.disc.system.constraint_matrix(q[:, -1])).reshape(-1, R.n)
    end = p[:, -1] - problem.p_goal - A.T @ nu[:, 0]
    knots = [np.array(problem.path_constraints(q[:9, k].reshape(3, 3), q[9:, k], u[:, min(k, N - 1)])).ravel()
             for k in range(N + 1)] if problem.path_constraints is not None else []
    g = np.concatenate([dynamics.ravel(order="F"), group.ravel(order="F"),
                        _cayley_inverse(problem.R_goal.T @ R_N), x_N - problem.x_goal, end, *knots])
    return h * np.sum(u ** 2), g


@pytest.mark.parametrize("body", ["sphere", "quadrotor"])
def test_the_group_terms_state_the_group_nlp_with_exact_derivatives(body):
    """The NLP of a GroupOptimalControlProblem stated as terms (`group_transcription`): at a
    random point its f and g are the rows written in the test, and its assembled gradient,
    Jacobian and Hessian of the Lagrangian equal CasADi's AD of the whole NLP."""
    from dmoc.optimal_control.nlp.group_transcription import group_transcription

    problem = _group_problem(body)
    T = group_transcription(problem)
    rng = np.random.default_rng(43)
    x, lam, sigma = rng.normal(scale=0.5, size=T.x_layout.size), rng.normal(size=T.g_layout.size), 1.3
    f, g = T.separable.values(x, T.p)
    f_written, g_written = _group_rows(problem, T, x)
    assert g.size == g_written.size and T.g_layout.numel("path_knots") == (8 if body == "quadrotor" else 0)
    _assert_exact(f, f_written, "f")
    _assert_exact(g, g_written, "g")

    oracle, assembled = _oracle(T), T.separable.derivatives()
    grad, jac = _dense(oracle["grad"](x, T.p)), _dense(oracle["jac"](x, T.p))
    hess = _dense(oracle["hess"](x, T.p, sigma, lam))
    assert np.abs(hess).max() > 0
    _assert_exact(_dense(assembled["nlp_grad_f"](x, T.p)[1]), grad, "grad f")
    _assert_exact(_dense(assembled["nlp_jac_g"](x, T.p)[1]), jac, "jac g")
    _assert_exact(_dense(assembled["nlp_hess_l"](x, T.p, sigma, lam)), hess, "triu hess L")
