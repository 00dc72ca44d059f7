"""Optimizer inputs that used to be accepted with another meaning: an IPOPT integer option
given as a non-integral float (max_iter 3.7 ran 3 iterations) or as a bool (True ran 1),
a bool for any IPOPT option, and a path constraint written as a comparison (q[0] < 0.5,
which is a 0/1 expression that g <= 0 imposes as "false"). Oracles: the messages, checked
by content, and the error class (`dmoc.DmocError`); IPOPT's iteration count for an
integral float; the values of the path Function for correct constraints."""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc._util import checks
from dmoc.optimal_control.solver.solving import SWITCHES


def problem(disc, **changes):
    return dmoc.OptimalControlProblem(disc, 4, **{"q_start": [0, 0, 0], "q_goal": [0, 1, 0],
                                                  **changes})


def refused(kind, words, call):
    with pytest.raises(kind, match=words) as info:
        call()
    assert isinstance(info.value, dmoc.DmocError)


@pytest.mark.parametrize("options, kind, words", [
    ({"max_iter": 3.7}, dmoc.InputError,
     r"`options\['max_iter'\]` must be an integer .*got 3.7, which IPOPT would truncate to 3"),
    ({"print_level": 0.5}, dmoc.InputError, r"`options\['print_level'\]` must be an integer"),
    ({"mumps_pivot_order": np.float64(2.5)}, dmoc.InputError, r"`options\['mumps_pivot_order'\]`"),
    ({"acceptable_iter": float("inf")}, dmoc.InputError, r"must be finite; got inf "),
    ({"max_iter": True}, dmoc.InputTypeError,
     r"`options\['max_iter'\]` must be an integer, not a bool; got True \(IPOPT would read it as 1\)"),
    ({"sb": True}, dmoc.InputTypeError, r"`options\['sb'\]` .*not a bool.*'yes' and 'no'"),
    ({"tol": np.bool_(False)}, dmoc.InputTypeError, r"`options\['tol'\]` .*not a bool"),
])
def test_ipopt_options_of_the_wrong_kind_are_refused(disc, options, kind, words):
    refused(kind, words, lambda: dmoc.optimize(problem(disc), options=options))
    refused(kind, words, lambda: dmoc.batch.optimize_many([problem(disc)], options=options,
                                                          client="tcp://127.0.0.1:1"))


def test_integral_floats_are_integers_and_reals_stay(disc, capfd):
    options = checks.ipopt_options("options", {"max_iter": 3.0, "tol": 1e-9, "mu_init": 1,
                                               "mu_strategy": "adaptive"})
    assert options == {"max_iter": 3, "tol": 1e-9, "mu_init": 1, "mu_strategy": "adaptive"}
    assert type(options["max_iter"]) is int
    result = dmoc.optimize(problem(disc), options={"max_iter": 3.0}, throw=False)
    capfd.readouterr()
    assert result.stats["iterations"] == 3 and result.status == "Maximum_Iterations_Exceeded"


def test_the_switch_entries_still_take_bools():
    """`optimize`'s switches in the deprecated options spelling are the bool entries."""
    assert set(checks.SWITCH_ENTRIES) == set(SWITCHES)
    entries = {name: not default for name, default in SWITCHES.items()}
    assert checks.ipopt_options("options", entries) == entries


@pytest.mark.parametrize("path, entry", [
    (lambda q, v, u: q[0] < 0.5, r"entry 0 is \(q_0<0\.5\)"),
    (lambda q, v, u: q[0] >= 0.5, "entry 0 is"),
    (lambda q, v, u: ca.vertcat(q[1] - 1, q[0] == 0), r"entry 1 is \(q_0==0\)"),
    (lambda q, v, u: ca.logic_and(q[0] < 1, q[1] < 1), "entry 0 is"),
])
def test_path_constraints_written_as_comparisons_are_refused(disc, path, entry):
    refused(dmoc.InputError, r"`path_constraints` must return expressions g imposed as g <= 0, "
            r"not comparisons; " + entry + r".*write q\[0\] < 0.5 as `q\[0\] - 0.5`"
            .replace("write", "Write"), lambda: problem(disc, path_constraints=path))


def test_path_constraints_with_a_branch_inside_pass(disc):
    """A comparison inside an expression (a branch of ca.if_else) is not the constraint."""
    ocp = problem(disc, path_constraints=lambda q, v, u: ca.vertcat(
        q[0] - 0.5, ca.if_else(q[1] < 0, -q[1], q[1]) - 2))
    g = ocp.path_constraints(q=ca.DM([0.3, -0.4, 0]), v=ca.DM.zeros(3), u=ca.DM.zeros(2),
                             w=ca.DM(0, 1))["g"]        # at one state (q, v, u)
    np.testing.assert_allclose(np.array(g).ravel(), [0.3 - 0.5, 0.4 - 2], rtol=0, atol=1e-15)
