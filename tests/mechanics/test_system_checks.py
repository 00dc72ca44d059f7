"""MechanicalSystem checks its data on symbols where it is given: a wrong size, a
Lagrangian without velocities, undeclared symbols, dependent constraint rows and names of
the wrong kind are refused naming the argument, every problem reported at once.
Oracle: the messages, checked by content (the argument they must name)."""

import casadi as ca
import numpy as np
import pytest

import dmoc


def kinetic(q, v):
    return 0.5 * ca.dot(v, v)


@pytest.mark.parametrize("kwargs, name", [
    (dict(lagrangian=lambda q, v: v), "lagrangian"),                 # a vector
    (dict(lagrangian=lambda q, v: ca.mtimes(v, v.T)), "lagrangian"),  # a matrix
    (dict(lagrangian=3.0), "lagrangian"),                            # not callable
    (dict(lagrangian=lambda q, v: v[7]), "lagrangian"),              # raises inside
    (dict(constraints=lambda q: ca.horzcat(1, 0)), "constraints"),   # 2 columns, n = 3
    (dict(constraints=lambda q: ca.SX.zeros(2, 4)), "constraints"),
    (dict(constraints="A"), "constraints"),
    (dict(force=lambda q, v, u: ca.vertcat(1, 2)), "force"),         # size 2, n = 3
    (dict(force=lambda q, v, u: ca.vertcat(u[0], u[1], 0), n_u=1), "force"),  # u too short
    (dict(force=5), "force"),
    (dict(names=("x", "y")), "names"),
])
def test_mechanical_system_rejects(kwargs, name):
    kwargs = {"lagrangian": kinetic, **kwargs}
    with pytest.raises(ValueError, match=f"`{name}`"):
        dmoc.MechanicalSystem(kwargs.pop("lagrangian"), 3, **kwargs)


def test_mechanical_system_reports_every_problem_at_once():
    with pytest.raises(ValueError) as info:
        dmoc.MechanicalSystem(lambda q, v: v, 3, constraints=lambda q: ca.horzcat(1, 0),
                              force=lambda q, v, u: ca.vertcat(1, 2), names=["a"])
    message = str(info.value)
    for name in ("`lagrangian`", "`constraints`", "`force`", "`names`"):
        assert name in message, message
    assert message.count("\n  - ") == 4


def test_mechanical_system_requires_a_lagrangian():
    """lagrangian=None must be rejected naming it, like any other non-callable."""
    with pytest.raises((TypeError, ValueError), match="`lagrangian`"):
        dmoc.MechanicalSystem(None, 3)


@pytest.mark.parametrize("kwargs, name", [(dict(n=0), "n"), (dict(n=1.5), "n"),
                                          (dict(n=3, n_u=-1), "n_u")])
def test_mechanical_system_sizes(kwargs, name):
    with pytest.raises(ValueError, match=f"`{name}`"):
        dmoc.MechanicalSystem(kinetic, **kwargs)


def test_mechanical_system_rejects_undeclared_symbols():
    stray = ca.SX.sym("stray")
    with pytest.raises(ValueError, match=r"`lagrangian` uses symbols .*stray") as info:
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v) + stray * q[0], 2,
                              force=lambda q, v, u: ca.vertcat(stray, 0))
    assert "`force` uses symbols" in str(info.value)     # every problem, at once


def test_mechanical_system_rejects_dependent_constraint_rows():
    with pytest.raises(ValueError, match=r"`constraints` must have linearly independent rows"):
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 3,
                              constraints=lambda q: ca.vertcat(ca.horzcat(1, 0, q[0]),
                                                               ca.horzcat(2, 0, 2 * q[0])))


def test_names_of_the_wrong_kind():
    with pytest.raises((TypeError, ValueError), match="`names`"):
        dmoc.MechanicalSystem(lambda q, v: 0.5 * ca.dot(v, v), 2, names=5)


def test_lagrangian_without_velocities():
    """Refused where it is given (before, it 'simulated' q = 0.1, 9.3, 18.9, ...)."""
    with pytest.raises(ValueError, match="`lagrangian` must depend on the velocities"):
        system = dmoc.MechanicalSystem(lambda q, v: ca.sin(q[0]), 1)
        dmoc.simulate(dmoc.discretize(system, 0.1), q0=[0.1], v0=[0.0], steps=3)


@pytest.mark.parametrize("make", [dmoc.systems.knife_edge, dmoc.systems.rolling_disk,
                                  dmoc.systems.spherical_pendulum])
def test_a_zero_velocity_is_allowed_without_evaluating_a(make):
    """`check_allowed_velocity` passes a zero v (signed zeros too) without A(q): the
    outcome `velocity_errors` gives from A(q) v, on random q, for zero and other v."""
    from dmoc.mechanics.given import check_allowed_velocity, velocity_errors
    system, rng = make(), np.random.default_rng(7)
    for _ in range(20):
        q = rng.uniform(-2.0, 2.0, system.n)
        for v in (np.zeros(system.n), -np.zeros(system.n), rng.uniform(-1.0, 1.0, system.n)):
            expected = velocity_errors("v", system, q[None, :], v[None, :])[0]
            try:
                check_allowed_velocity("v", system, q, v)
                got = None
            except dmoc.InputError as err:
                got = err
            assert (got is None) == (expected is None)
            assert got is None or str(got) == str(expected)
            if not v.any():
                assert got is None
