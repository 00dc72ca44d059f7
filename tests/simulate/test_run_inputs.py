"""simulate refuses a horizon whose arrays cannot fit in memory before allocating them,
naming `steps`, and a failure caused by a tolerance below round-off names `tol`.

Oracles, none taken from the code under test: the machine's memory from os.sysconf; a
lower bound of the bytes a run holds, its q and p alone (2 (N+1) n float64 values); the
floor of round-off, machine epsilon (a relative residual of 1e-297 is not reachable in
float64 arithmetic)."""

import os
import re

import numpy as np
import pytest

import dmoc

Q0, V0 = [0.0, 0.0, 0.0], [1.0, 0.0, 1.0]


def test_too_many_steps_are_refused_naming_steps_and_bytes(disc):
    steps = 10 ** 10
    with pytest.raises(dmoc.InputError, match=rf"`steps` = {steps} needs at least \S+ bytes") as info:
        dmoc.simulate(disc, q0=Q0, v0=V0, steps=steps)
    assert isinstance(info.value, dmoc.DmocError)
    needed, available = (float(x) for x in re.findall(r"([\d.]+e\+\d+) bytes", str(info.value)))
    assert needed >= 8 * 2 * (steps + 1) * disc.system.n
    assert available == pytest.approx(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"),
                                      rel=1e-2)
    assert needed > available


def test_a_tolerance_below_round_off_names_tol(disc):
    with pytest.raises(dmoc.SolverError) as info:
        dmoc.simulate(disc, q0=Q0, v0=V0, steps=5, tol=1e-300)
    message = str(info.value)
    assert isinstance(info.value, dmoc.DmocError)
    assert "`tol` = 1.0e-300 is below the round-off floor" in message
    assert "smaller step h" not in message
    floor = float(re.search(r"use tol >= (\S+) ", message).group(1))
    assert 1e3 * floor >= np.finfo(float).eps      # the suggested tol is reachable


def test_a_reachable_tolerance_still_converges(disc):
    assert dmoc.simulate(disc, q0=Q0, v0=V0, steps=5, tol=1e-14).success
