"""The unclear errors of issue 45 that are not the batch's (docs/verification.md, "Unclear
errors made clear"): each is now one line naming what to change, or a result instead of a
NumPy error, and a long run's table shows its progress."""

import numpy as np
import pytest

import dmoc
from dmoc._util import numeric
from dmoc.cli import main, output

FACTORIES = '''
import dmoc

def point(mass=1.0):
    if mass < 0:
        raise ValueError("mass must be positive")
    return dmoc.MechanicalSystem(lambda q, v: mass / 2 * v[0] ** 2, 1, n_u=1)

def broken():
    raise ValueError("the table of masses is missing")
'''


@pytest.fixture
def factories(tmp_path):
    path = tmp_path / "factories.py"
    path.write_text(FACTORIES)
    return path


def error_line(capsys):
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("dmoc: error")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_a_factorys_own_error_is_not_blamed_on_param(factories, capsys):
    assert main(["simulate", f"{factories}:broken", "--steps", "3"]) == 2
    assert error_line(capsys) == ("dmoc: error: argument SYSTEM: broken() raised ValueError: "
                                  "the table of masses is missing")
    assert main(["simulate", f"{factories}:point", "--param", "mass=-1", "--steps", "3"]) == 2
    assert error_line(capsys) == ("dmoc: error: argument --param: point(mass=-1) raised "
                                  "ValueError: mass must be positive")


@pytest.mark.parametrize("command", ["optimize", "simulate"])
def test_a_step_below_the_smallest_normal_float_is_one_line(command, capsys):
    assert main([command, "knife-edge", "--duration", "1e-320", "--steps", "100"]) == 2
    line = error_line(capsys)
    assert line.startswith("dmoc: error: argument --duration: `h` must be at least "
                           "2.2250738585072014e-308")


def test_sample_and_control_at_no_times_are_empty():
    for rule in ("midpoint", "lobatto3"):
        disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, rule)
        traj = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=4).trajectory
        sample = traj.sample([])
        assert [a.shape for a in sample] == [(0,), (0, 3), (0, 3), (0, 3), (0, 2)]
        assert traj.control([]).shape == (0, 2)


def test_a_long_tables_progress_is_shown_and_its_text_is_savetxts(monkeypatch):
    """Blocks of 4 rows and a message after each: the text is NumPy's savetxt's, byte for
    byte (its own writer is the oracle), and the messages count the rows."""
    import io
    table = np.random.default_rng(0).normal(size=(10, 3))
    table[2, 1] = np.nan
    expected = io.StringIO()
    np.savetxt(expected, table, delimiter=",", header="a,b,c", comments="", fmt="%.17g")
    monkeypatch.setattr(output, "BLOCK", 4)
    monkeypatch.setattr(output, "PROGRESS_SECONDS", -1.0)
    written, heard = io.StringIO(), []
    output.write_table(written, ["a", "b", "c"], table, heard.append, "run.csv")
    assert written.getvalue() == expected.getvalue()
    assert heard == [f"writing run.csv: {k} of 10 rows" for k in (4, 8, 10)]


def test_long_diagnostics_go_chunk_by_chunk_with_the_same_bits(monkeypatch):
    """`numeric.per_step` over more steps than a chunk (made small here), with a last
    partial chunk, against CasADi's map over all steps. The map is kept per count
    (`numeric.mapped`), so the small chunk's never stands in for the real one's."""
    monkeypatch.setattr(numeric, "CHUNK", 8)
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 0.1, "lobatto3")
    traj = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=21).trajectory
    args = (traj.q[:-1], traj.p[:-1], traj.q[1:], traj.p[1:], traj.s, traj.h)
    (E,) = numeric.per_step(disc.step_energy, traj.steps, *args)
    whole = np.array(disc.step_energy.map(traj.steps)(*(a.T for a in args[:-1]), traj.h)).T
    assert E.shape == (21, 1) and np.array_equal(E, whole)
