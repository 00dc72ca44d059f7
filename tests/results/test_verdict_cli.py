"""The verdict at the command line and at the API's boundary: ``dmoc optimize`` exits 1 on
a failed verdict and still writes its files, whose summary says why (the car of issue 23
as a user's file); `check` must be a bool."""

import json

import pytest

import dmoc
from dmoc.cli import main
from dmoc.problems import knife_edge_parking

CAR_FILE = "import dmoc\n\n\ndef car():\n    return dmoc.systems.car()\n"


def test_the_car_of_the_issue_exits_1_and_writes_its_files(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "car.py").write_text(CAR_FILE)
    code = main(["optimize", "car.py:car", "--goal", "40,3.5,0,0", "--duration", "3",
                 "--steps", "60", "--out", "o"])
    assert code == 1
    for suffix in (".npz", ".csv", "_summary.json", "_path.png"):
        assert (tmp_path / "o" / f"car{suffix}").exists()
    summary = json.loads((tmp_path / "o" / "car_summary.json").read_text())
    assert summary["success"] is False and summary["status"] == "not_replayable"
    assert summary["verdict"] == "not_replayable" and "other roots" in summary["message"]
    assert summary["replay_q"] > 1.0                   # metres, recomputed by the CLI
    assert "solver failed (not_replayable)" in capsys.readouterr().err


def test_a_sound_optimum_keeps_exit_0_and_says_passed(tmp_path, capsys):
    assert main(["optimize", "knife-edge", "--steps", "30", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "knife_edge_summary.json").read_text())
    assert summary["success"] and summary["verdict"] == "passed"


def test_check_must_be_a_bool():
    with pytest.raises(dmoc.InputTypeError, match="`check` must be True or False; got 'yes'"):
        dmoc.optimize(knife_edge_parking(20), check="yes")
