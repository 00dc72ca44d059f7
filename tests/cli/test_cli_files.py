"""A `dmoc` run writes its files all together or not at all (`dmoc._util.files.staged_run`),
cleans up what killed saves left behind, and refuses command-line inputs that would
otherwise be read wrongly, each with one line naming the argument and exit 2."""

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import dmoc
from dmoc._util import files
from dmoc.cli import main

ROOT = pathlib.Path(__file__).parents[2]


def snapshot(folder):
    """{name: bytes} of the files shown in `folder` (links followed; the sets' hidden
    folders, `dmoc._util.file_set`, left out)."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if not p.name.endswith(".dmoc")}


def fail_on_call(monkeypatch, number, error=OSError(27, "File too large")):
    """Make the `number`-th os.replace of dmoc's writes raise `error` (every other call,
    the undoing of a failed commit included, goes through)."""
    calls, replace = [], os.replace

    def replace_or_fail(source, target):
        calls.append(target)
        if len(calls) == number:
            raise error
        return replace(source, target)

    monkeypatch.setattr(files.os, "replace", replace_or_fail)
    return calls


SIMULATE = ["simulate", "knife-edge", "--steps", "5"]


# npz, csv, summary and the knife edge's five plots (and the GIF) are each an atomic write;
# then the commit moves them in, in sorted order: csv, gif, npz, ...
@pytest.mark.parametrize("extra, failing", [((), 3), ((), 8 + 2), (("--animate",), 9 + 3)],
                         ids=["third file written", "second file moved",
                              "a file new to the folder moved, the next one fails"])
def test_a_failed_second_run_leaves_the_complete_old_set(tmp_path, monkeypatch, capsys, extra,
                                                         failing):
    assert main([*SIMULATE, "--out", str(tmp_path)]) == 0
    (tmp_path / "notes.txt").write_text("the user's")
    before = snapshot(tmp_path)
    assert len([n for n in before if n.endswith(".png")]) == 5
    calls = fail_on_call(monkeypatch, failing)
    assert main(["simulate", "knife-edge", "--steps", "7", *extra, "--out", str(tmp_path)]) == 2
    monkeypatch.undo()
    assert len(calls) >= failing
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("dmoc: error: argument --out:") and "File too large" in err
    assert "nothing there was changed" in err
    assert snapshot(tmp_path) == before        # every old file, byte for byte; no temporary
    assert dmoc.Trajectory.load(tmp_path / "knife_edge.npz").steps == 5


def test_a_new_run_replaces_the_old_set_as_a_whole(tmp_path, capsys):
    """The old run's GIF, which the new run does not write, goes with the rest of its set;
    files of other runs and the user's stay."""
    assert main([*SIMULATE, "--animate", "--out", str(tmp_path)]) == 0
    assert main(["simulate", "rolling-disk", "--steps", "5", "--out", str(tmp_path)]) == 0
    (tmp_path / "notes.txt").write_text("the user's")
    others = {n: b for n, b in snapshot(tmp_path).items() if not n.startswith("knife_edge")}
    assert main(["simulate", "knife-edge", "--steps", "7", "--out", str(tmp_path)]) == 0
    after = snapshot(tmp_path)
    assert "knife_edge.gif" not in after and "knife_edge_states.png" in after
    assert {n: b for n, b in after.items() if not n.startswith("knife_edge")} == others
    assert dmoc.Trajectory.load(tmp_path / "knife_edge.npz").steps == 7


def test_demo_that_cannot_write_exits_2_with_its_summary(tmp_path, monkeypatch, capsys):
    (tmp_path / "summary.txt").write_text("an earlier demo\n")
    fail_on_call(monkeypatch, 3, OSError(28, "No space left on device"))
    assert main(["demo", "--steps", "20", "--opt-steps", "2", "--out", str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert "Dirac integrator" in out and "knife_edge" in out
    lines = [line for line in err.splitlines() if line.startswith("dmoc: error")]
    assert len(lines) == 1 and "argument --out" in lines[0] and "No space left" in lines[0]
    assert snapshot(tmp_path) == {"summary.txt": b"an earlier demo\n"}


def _dead_pid():
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_the_next_save_removes_stale_temporaries(tmp_path):
    dead, alive = _dead_pid(), os.getppid()
    stale = [f".run.npz.{dead}.0123456789ab.tmp", f".run.npz.{alive}.0123456789ac.tmp",
             ".run.npz.0123456789ad.tmp", f".anim.{dead}.0123456789ae.tmp.gif"]
    for name in stale:
        (tmp_path / name).write_bytes(b"partial")
    run_folder = tmp_path / f".dmoc-run.{dead}.0123456789af.tmp"
    run_folder.mkdir()
    (run_folder / "knife_edge.npz").write_bytes(b"partial")
    hour_ago = time.time() - files.STALE_SECONDS - 60
    day_ago = time.time() - files.LIVE_STALE_SECONDS - 60
    os.utime(tmp_path / stale[1], (day_ago, day_ago))         # alive, but a day old
    alive_hour = tmp_path / f".run.npz.{alive}.0123456789b1.tmp"   # alive, an hour: in use
    alive_hour.write_bytes(b"being written")
    os.utime(alive_hour, (hour_ago, hour_ago))
    young = tmp_path / f".run.npz.{alive}.0123456789b0.tmp"   # alive and recent: in use
    young.write_bytes(b"being written")
    mine = tmp_path / "mine.tmp"                              # not dmoc's name: kept
    mine.write_bytes(b"")
    os.utime(tmp_path / stale[2], (hour_ago, hour_ago))       # no PID (older names): by age
    traj = dmoc.simulate(dmoc.discretize(dmoc.systems.knife_edge(), 0.1), q0=[0, 0, 0],
                         v0=[1, 0, 1], steps=3).trajectory
    traj.save(tmp_path / "run.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [young.name, alive_hour.name, mine.name, "run.npz"])


KILLED = '''
import sys, time
import numpy as np
import dmoc
traj = dmoc.simulate(dmoc.discretize(dmoc.systems.knife_edge(), 0.1), q0=[0, 0, 0],
                     v0=[1, 0, 1], steps=3).trajectory
savez = np.savez
def slow(file, **arrays):
    savez(file, **arrays)
    print("writing", flush=True)
    time.sleep(600)
np.savez = slow
traj.save(sys.argv[1])
'''


def test_temporaries_of_a_killed_save_go_with_the_next_save(tmp_path):
    script = tmp_path / "child.py"
    script.write_text(KILLED)
    out = tmp_path / "out"
    out.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    child = subprocess.Popen([sys.executable, str(script), str(out / "run.npz")], env=env,
                             stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "writing"
    child.send_signal(signal.SIGKILL)
    child.wait()
    left = [p.name for p in out.iterdir()]
    assert len(left) == 1 and left[0].startswith(".run.npz.") and left[0].endswith(".tmp")
    assert main(["simulate", "knife-edge", "--steps", "3", "--out", str(out)]) == 0
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


# ---- command-line inputs that were read wrongly or failed unclearly: one line, exit 2 ----

KWARGS_FACTORY = '''
import dmoc

def point(**params):
    """A free particle of mass params['mass'] (default 1)."""
    mass = params.get("mass", 1.0)
    return dmoc.MechanicalSystem(lambda q, v: mass / 2 * v[0] ** 2, 1, n_u=1)

def exits():
    raise SystemExit(3)
'''


@pytest.fixture()
def user_files(tmp_path):
    (tmp_path / "kw.py").write_text(KWARGS_FACTORY)
    (tmp_path / "exits.py").write_text("import sys\nsys.exit(0)\n")
    (tmp_path / "cls.py").write_text("from dmoc import MechanicalSystem\n")
    (tmp_path / "dir.py").mkdir()
    np.save(tmp_path / "complex.npy", np.array([[1 + 2j, 0], [0, 1j]]))
    np.save(tmp_path / "bool.npy", np.array([[True, False], [False, True]]))
    np.save(tmp_path / "strings.npy", np.array([["a", "b"], ["c", "d"]]))
    np.savez(tmp_path / "u.npz", u=np.zeros((2, 2)))
    (tmp_path / "binary.csv").write_bytes(b"\xff\xfe\x00\x81")
    return tmp_path


def _one_line_error(capsys):
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("dmoc: error")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("argv, argument, says", [
    (["simulate", "knife-edge", "--out", ""], "--out", "must name a folder"),
    (["optimize", "knife-edge", "--out", "  "], "--out", "must name a folder"),
    (["demo", "--out", ""], "--out", "must name a folder"),
    (["simulate", "knife-edge", "--controls", "{f}/complex.npy"], "--controls", "complex numbers"),
    (["simulate", "knife-edge", "--controls", "{f}/bool.npy"], "--controls", "booleans"),
    (["simulate", "knife-edge", "--controls", "{f}/strings.npy"], "--controls", "strings"),
    (["simulate", "knife-edge", "--controls", "{f}/u.npz"], "--controls", ".npz archive"),
    (["simulate", "knife-edge", "--controls", "{f}/binary.csv"], "--controls", "not a text file"),
    (["simulate", "{f}/exits.py:f"], "SYSTEM", "sys.exit(0)"),
    (["simulate", "{f}/kw.py:exits"], "SYSTEM", "sys.exit(3)"),
    (["simulate", "{f}/dir.py:f"], "SYSTEM", "is a folder"),
    (["simulate", "{f}/cls.py:MechanicalSystem"], "SYSTEM", "the class 'MechanicalSystem' needs lagrangian, n"),
])
def test_unclear_inputs_exit_2_with_one_line(user_files, argv, argument, says, capsys):
    assert main([a.format(f=user_files) for a in argv]) == 2
    line = _one_line_error(capsys)
    assert f"argument {argument}" in line and says in line, line


def test_param_of_a_factory_taking_keywords_is_passed_on(user_files, tmp_path, capsys):
    """--param mass=2 reaches factory(**params): the start momentum is mass * v0."""
    assert main(["simulate", f"{user_files}/kw.py:point", "--param", "mass=2", "--velocity",
                 "1.5", "--steps", "3", "--out", str(tmp_path / "o")]) == 0
    traj = dmoc.Trajectory.load(tmp_path / "o" / "point.npz")
    assert traj.p[0, 0] == pytest.approx(2 * 1.5, rel=1e-12)
    summary = json.loads((tmp_path / "o" / "point_summary.json").read_text())
    assert summary["success"]
