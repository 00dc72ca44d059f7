"""benchmarks/batch.py, the maintained batch benchmark, runs at its smallest size against
today's code (its figures are not checked: no timing in tests; it checks itself that every
batch result succeeds and prints the batch's distance from the serial results)."""

import importlib.util
import os
import pathlib

import pytest

pytest.importorskip("distributed")

SCRIPT = pathlib.Path(__file__).parents[2] / "benchmarks" / "batch.py"


def test_the_batch_benchmark_runs_at_its_smallest_size(capsys, monkeypatch):
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.setenv(var, os.environ.get(var, "1"))   # what the script sets, restored after
    spec = importlib.util.spec_from_file_location("batch_benchmark", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    found = module.main(["--count", "8", "--sim-steps", "20", "--repeat", "1"])
    out = capsys.readouterr().out
    assert set(found) == {"optimize", "simulate"} and all(len(r) == 1 for r in found.values())
    assert "optimize 8 at N = 20" in out and "simulate 8 x 20 steps" in out
    assert out.count("max |diff| 0.0e+00") == 2        # bit for bit the serial results
