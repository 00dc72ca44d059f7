"""System definitions that used to be accepted with a wrong meaning, or refused with a
message that did not say what was wrong: coordinate names that break the CSV table
(repeated, or holding a comma), and Python math or numpy functions that need numbers
applied to the CasADi symbols of L, H, A(q) or f. Oracle: the messages, checked by content,
and the error class (`dmoc.DmocError`); correct definitions next to them still pass."""

import math

import casadi as ca
import numpy as np
import pytest

import dmoc


def kinetic(q, v):
    return 0.5 * ca.dot(v, v)


def hamiltonian(q, p):
    return 0.5 * ca.dot(p, p)


def refused(build, words):
    """`build()` raises a DmocError matching `words`; the error."""
    with pytest.raises(dmoc.InputError, match=words) as info:
        build()
    assert isinstance(info.value, dmoc.DmocError)
    return info.value


@pytest.mark.parametrize("kind, primary", [(dmoc.MechanicalSystem, kinetic),
                                           (dmoc.HamiltonianSystem, hamiltonian)])
@pytest.mark.parametrize("names, words", [
    (("x", "x", "theta"), r"`names` must be distinct .*\['x'\] more than once"),
    (("x,1", "y", "theta"), r"`names` must not contain commas .*\['x,1'\].*'x_1'"),
    (("x", "y\n", "theta"), r"`names` must not contain commas or line breaks"),
])
def test_names_that_break_the_csv_table_are_refused(kind, primary, names, words):
    refused(lambda: kind(primary, 3, names=names), words)


def test_distinct_plain_names_are_kept():
    assert dmoc.MechanicalSystem(kinetic, 3, names=("x", "y", "theta")).names == ("x", "y", "theta")
    assert dmoc.systems.knife_edge().names == ("x", "y", "theta")


@pytest.mark.parametrize("kwargs, name", [
    (dict(lagrangian=lambda q, v: kinetic(q, v) + math.sin(q[0])), "lagrangian"),
    (dict(lagrangian=lambda q, v: kinetic(q, v) * np.float64(q[1])), "lagrangian"),
    # a NaN in A(q) used to reach numpy's rank test: "SVD did not converge"
    (dict(constraints=lambda q: ca.horzcat(-math.sin(q[2]), math.cos(q[2]), 0)), "constraints"),
    (dict(holonomic=lambda q: q[1] - math.exp(q[0])), "holonomic"),
    (dict(force=lambda q, v, u: ca.vertcat(math.cos(q[2]) * u[0], 0, 0), n_u=1), "force"),
])
def test_math_functions_on_symbols_are_named(kwargs, name):
    error = refused(lambda: dmoc.MechanicalSystem(**{"lagrangian": kinetic, "n": 3, **kwargs}),
                    f"`{name}` must be built from CasADi operations")
    assert "ca.sin" in str(error) and "NaN" in str(error)


def test_math_functions_in_a_hamiltonian_are_named():
    refused(lambda: dmoc.HamiltonianSystem(lambda q, p: hamiltonian(q, p) - math.cos(q[0]), 1),
            r"`hamiltonian` must be built from CasADi operations.*ca\.sin")


@pytest.mark.parametrize("lagrangian", [
    lambda q, v: kinetic(q, v) + math.sin(q),          # float() of a vector: CasADi assertion
    lambda q, v: kinetic(q, v) + int(q[0]),            # int() of a symbol
    lambda q, v: kinetic(q, v) if q[0] > 0 else 0,     # truth value of a comparison
    lambda q, v: kinetic(q, v) + np.asarray(q, dtype=float).sum(),   # numpy's conversion
])
def test_numeric_conversions_that_raise_get_the_hint(lagrangian):
    refused(lambda: dmoc.MechanicalSystem(lagrangian, 3),
            r"(?s)`lagrangian` failed on symbols.*use CasADi's functions on them \(ca\.sin")


def test_failures_of_other_kinds_get_no_casadi_hint():
    error = refused(lambda: dmoc.MechanicalSystem(lambda q, v: v[7], 3), "`lagrangian` failed")
    assert "ca.sin" not in str(error)


@pytest.mark.parametrize("lagrangian", [
    kinetic,                                                  # does not depend on q
    lambda q, v: math.sin(0.3) * kinetic(q, v) + math.pi,     # math on numbers is fine
    lambda q, v: kinetic(q, v) - np.cos(q[0]) + np.hypot(q[1], q[2]),   # numpy on SX maps to CasADi
])
def test_legitimate_lagrangians_pass(lagrangian):
    s = dmoc.MechanicalSystem(lagrangian, 3)
    L = float(s.lagrangian([0.1, 0.2, 0.3], [1.0, 0.0, 0.0]))
    assert math.isfinite(L) and L == pytest.approx(float(lagrangian(
        ca.DM([0.1, 0.2, 0.3]), ca.DM([1.0, 0.0, 0.0]))), rel=1e-15)


@pytest.mark.parametrize("kwargs, name, words", [
    ({"constraints": lambda q: [[-ca.sin(q[2]), ca.cos(q[2]), 0]]}, "constraints", "each row with ca.horzcat"),
    ({"force": lambda q, v, u: [u[0] * ca.cos(q[2]), u[0] * ca.sin(q[2]), 0], "n_u": 1}, "force",
     "stack the entries with ca.vertcat"),
])
def test_lists_of_expressions_get_the_hint(kwargs, name, words):
    """A Python list of CasADi expressions is not an expression: the message says how to
    build one instead of listing CasADi's constructors."""
    with pytest.raises(dmoc.InputError, match=rf"`{name}` must return a CasADi expression; got a list") as info:
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 3, **kwargs)
    assert words in str(info.value) and "Possible prototypes" not in str(info.value)
    assert isinstance(info.value, dmoc.DmocError)


def test_a_list_of_numbers_is_still_a_constant():
    system = dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 3, constraints=lambda q: [[0.0, 1.0, 0.0]])
    assert system.m == 1


@pytest.mark.parametrize("force", [lambda q, v, u: ca.vertcat(u[0], 0), lambda q, v, u: u],
                         ids=["reads an entry", "returns u"])
def test_a_force_reading_u_without_n_u_says_to_declare_it(force):
    """n_u left at 0: u has no entries, so the force fails (a slice out of range) or returns
    shape (0, 1); either message says to declare n_u."""
    with pytest.raises(dmoc.InputError, match=r"(?s)`force` .*With n_u = 0 the force is called with u of "
                                         r"shape \(0,\): if it reads u, declare the number of controls, n_u=k\."):
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 2, force=force)
