"""The `dmoc` command: every bad argument exits 2 with one line naming it and no traceback;
free goal entries reach the problem as free; a failed table write keeps the previous files.

Oracles: the messages by content; the files written by a previous run, byte for byte;
files damaged here by hand."""

import json

import numpy as np
import pytest

import dmoc
from dmoc.cli import main


FACTORIES = '''
import dmoc


def boom(mass=1.0):
    raise RuntimeError("kaboom")


def lc():
    return dmoc.systems.lc_circuit()
'''


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    (folder / "factories.py").write_text(FACTORIES)
    np.save(folder / "good.npy", np.zeros((5, 2)))
    (folder / "truncated.npy").write_bytes((folder / "good.npy").read_bytes()[:100])
    (folder / "random.npy").write_bytes(b"\x93NUMPYxx" * 10)
    np.save(folder / "objects.npy", np.array([1, "a"], dtype=object), allow_pickle=True)
    (folder / "letters.csv").write_text("a,b\n1,x\n")
    (folder / "empty.csv").write_text("")
    (folder / "header.csv").write_text("force,torque\n")
    return folder


@pytest.mark.parametrize("argv, argument, words", [
    (["simulate", "{f}/factories.py:boom"], "SYSTEM", "the factory raised RuntimeError: kaboom"),
    (["simulate", "{f}/factories.py:lc", "--rule", "trapezoid"], "--rule", "rule='midpoint'"),
    (["simulate", "knife-edge", "--controls", "{f}/truncated.npy"], "--controls", "cannot read"),
    (["simulate", "knife-edge", "--controls", "{f}/random.npy"], "--controls", "cannot read"),
    (["simulate", "knife-edge", "--controls", "{f}/objects.npy"], "--controls", "holds Python objects (dtype object), which dmoc never unpickles"),
    (["simulate", "knife-edge", "--controls", "{f}/letters.csv"], "--controls", "'x'"),
    (["simulate", "knife-edge", "--controls", "{f}/empty.csv"], "--controls", "it is empty"),
    (["simulate", "knife-edge", "--controls", "{f}/header.csv"], "--controls", "no rows of numbers"),
    (["simulate", "knife-edge", "--controls", "{f}"], "--controls", "is not a file"),
    (["simulate", "knife-edge", "--steps", "1e3"], "--steps", "positive integer"),
    (["simulate", "knife-edge", "--duration", "nan"], "--duration", "finite positive"),
    (["simulate", "knife-edge", "--param", "mass=nan"], "--param", "`mass` must be finite"),
    (["simulate", "knife-edge", "--param", "=1"], "--param", "NAME=VALUE"),
    (["simulate", "knife-edge", "--start", "0,0,inf"], "--start", "must be finite"),
    (["simulate", "knife-edge", "--velocity", "a,b,c"], "--velocity", "must be a number"),
    (["optimize", "knife-edge", "--max-iter", "0"], "--max-iter", "positive integer"),
    (["optimize", "knife-edge", "--start", "0,0,0,0"], "--start", "3 entries"),
    (["optimize", "knife-edge", "--unknown", "1"], "unrecognized arguments", "--unknown"),
    (["optimize", "{f}/factories.py"], "SYSTEM", "path/to/file.py:factory"),
    (["demo", "--opt-steps", "-1"], "--opt-steps", "positive integer"),
])
def test_more_bad_arguments_exit_2_with_one_line(files, argv, argument, words, capsys):
    assert main([a.format(f=files) for a in argv]) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("dmoc: error") and argument in lines[0], err
    assert words in lines[0] and "Traceback" not in err


def test_free_goal_entries_reach_the_problem_as_free(tmp_path, capsys):
    assert main(["optimize", "rolling-disk", "--steps", "10", "--goal", "1,1,free,1.5",
                 "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "rolling_disk_summary.json").read_text())
    assert summary["success"] is True
    np.testing.assert_allclose(dmoc.Trajectory.load(tmp_path / "rolling_disk.npz").q[-1, [0, 1, 3]],
                               [1, 1, 1.5], atol=1e-9)


def test_failed_table_write_keeps_the_previous_files(tmp_path, monkeypatch, capsys):
    argv = ["simulate", "knife-edge", "--steps", "5", "--out", str(tmp_path)]
    assert main(argv) == 0
    before = shown(tmp_path)

    def fails_half_way(file, *args, **kwargs):
        file.write("t,x\n0,")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savetxt", fails_half_way)
    assert main(["simulate", "knife-edge", "--steps", "7", "--out", str(tmp_path)]) == 2
    monkeypatch.undo()
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("dmoc: error: argument --out:") and "No space left" in err
    assert (tmp_path / "knife_edge.csv").read_bytes() == before["knife_edge.csv"]
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    # the run's files are written together or not at all: the .npz of the failed run,
    # written before its table, is not in place either (tests/cli/test_cli_files.py)
    assert dmoc.Trajectory.load(tmp_path / "knife_edge.npz").steps == 5
    assert shown(tmp_path) == before


def shown(folder):
    """{name: bytes} of the files shown in `folder` (links followed, the sets' hidden
    folders left out)."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if not p.name.endswith(".dmoc")}
