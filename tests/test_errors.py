"""The family of dmoc.errors: an input error is a DmocError and a ValueError or TypeError
at once, so callers can catch either; a solver failure is neither. Oracle: the exception
classes Python itself reports (`isinstance`, `issubclass`)."""

import pytest

import dmoc


def test_input_errors_are_dmoc_errors_and_builtin_errors(disc):
    with pytest.raises(dmoc.InputError, match="`steps`") as value:
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=0)
    with pytest.raises(dmoc.InputTypeError, match="`q0`") as kind:
        dmoc.simulate(disc, q0="abc", v0=[1, 0, 0], steps=2)
    assert isinstance(value.value, (dmoc.DmocError, ValueError))
    assert isinstance(kind.value, dmoc.DmocError) and isinstance(kind.value, TypeError)
    assert issubclass(dmoc.TrajectoryFileError, dmoc.InputError)
    assert issubclass(dmoc.MissingFileError, dmoc.DmocError)
    assert issubclass(dmoc.MissingFileError, FileNotFoundError)
    assert not issubclass(dmoc.SolverError, (ValueError, TypeError))
