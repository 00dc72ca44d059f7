"""Ctrl-C keeps the work: a SIGINT sent to a child process during `simulate`, `optimize`
and a `dmoc` run. The child says when the long run is under way (a line on stdout: its
first chunks of steps evaluated, or IPOPT's log at its first iteration); only then is the
signal sent, so it lands inside the run. The kept steps are checked against an
uninterrupted run of as many steps, the last iterate against IPOPT's own log."""

import json
import os
import pathlib
import re
import signal
import subprocess
import sys

import numpy as np
import pytest

import dmoc
from dmoc._util import compiled
from dmoc.simulation import stepper

ROOT = pathlib.Path(__file__).parents[1]
pytestmark = pytest.mark.skipif(os.name != "posix", reason="sends SIGINT to a child process")

# Runs in the child: `chunks` of the stepper (1024 steps each) evaluated, then it says
# "started" and, with `hold`, waits inside the next one for the signal.
HOOK = '''
import sys, time
from dmoc.simulation import stepper
calls = []
original = stepper.DiracStepper._chunk
def chunk(self, *args):
    calls.append(1)
    if len(calls) == {chunks} + 1:
        print("started", flush=True)
        if {hold}:
            time.sleep(600)
    original(self, *args)
stepper.DiracStepper._chunk = chunk
'''

SIMULATE = '''
import json
import numpy as np
import dmoc
disc = dmoc.discretize(dmoc.systems.knife_edge(incline=0.2), 0.01)
run = dict(q0=[0, 0, 0], v0=[1, 0, 1], jit={jit})
dmoc.simulate(disc, steps=3, **run)          # builds (and compiles) the step first
{hook}
try:
    res = dmoc.simulate(disc, steps=10 ** 6, throw={throw}, **run)
    how = "returned"
except dmoc.Interrupted as err:
    res, how = err.result, "raised"
k = res.stats["completed_steps"]
stepper.DiracStepper._chunk = original
ref = dmoc.simulate(disc, steps=max(k, 1), **run).trajectory
same = k == 0 or all(np.array_equal(getattr(res.trajectory, f), getattr(ref, f))
                     for f in ("t", "q", "p", "lam", "u"))
print("RESULT", json.dumps({{"how": how, "status": res.status, "success": res.success,
                            "message": res.message, "k": k, "steps": res.trajectory.steps,
                            "same": bool(same)}}), flush=True)
'''

OPTIMIZE = '''
import json
import dmoc
from dmoc import problems
problem = problems.knife_edge_parking(6000)
try:
    res = dmoc.optimize(problem, throw={throw}, options={{"print_level": 5}})
    how = "returned"
except dmoc.Interrupted as err:
    res, how = err.result, "raised"
print("RESULT", json.dumps({{"how": how, "status": res.status, "success": res.success,
                            "message": res.message, "iterations": res.stats["iterations"],
                            "return_status": res.stats["return_status"], "cost": res.cost,
                            "steps": res.trajectory.steps}}), flush=True)
'''

ITERATION = re.compile(r"^\s*(\d+)r?\s+([-+0-9.eE]+)\s")    # a line of IPOPT's iteration log


def interrupt(argv, ready, tmp_path):
    """Start `argv` in `tmp_path`, read its stdout until a line matches `ready`, send
    SIGINT; return (exit code, stdout, stderr)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1"}
    child = subprocess.Popen(argv, cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    seen = []
    try:
        for line in child.stdout:
            seen.append(line)
            if re.search(ready, line):
                child.send_signal(signal.SIGINT)
                break
        else:
            pytest.fail("the child ended before its long run started:\n" + "".join(seen)
                        + child.stderr.read())
        out, err = child.communicate(timeout=300)
    finally:
        if child.poll() is None:
            child.kill()
    return child.returncode, "".join(seen) + out, err


def result_of(stdout):
    line = next(line for line in stdout.splitlines() if line.startswith("RESULT "))
    return json.loads(line.removeprefix("RESULT "))


def script(tmp_path, text):
    path = tmp_path / "child.py"
    path.write_text(text)
    return [sys.executable, str(path)]


@pytest.mark.parametrize("throw", [False, True])
def test_simulate_interrupted_in_casadi_keeps_the_steps_so_far(tmp_path, throw):
    """The signal lands wherever the virtual machine is (inside CasADi's evaluation of a
    chunk, as a rule): the chunk it cut short is dropped, every step before is kept."""
    hook = HOOK.format(chunks=1, hold=False)
    code, out, err = interrupt(script(tmp_path, SIMULATE.format(jit=False, hook=hook,
                                                               throw=throw)),
                               "^started", tmp_path)
    res = result_of(out)
    assert code == 0, err
    assert res["how"] == ("raised" if throw else "returned")
    assert res["status"] == "interrupted" and res["success"] is False
    assert "interrupted" in res["message"]
    assert f"after {res['k']} of 1000000 steps" in res["message"]
    assert 1024 <= res["k"] < 10 ** 6 and res["k"] % stepper.CHUNK == 0
    assert res["steps"] == res["k"] and res["same"]


@pytest.mark.parametrize("jit", [False, True])
def test_simulate_interrupted_between_chunks_keeps_the_completed_chunks(tmp_path, jit):
    """The signal arrives after two chunks, before the third is evaluated: exactly the
    2 * CHUNK steps of the first two are kept, equal to an uninterrupted run's."""
    if jit and compiled.compiler() is None:
        pytest.skip("no C compiler")
    hook = HOOK.format(chunks=2, hold=True)
    code, out, err = interrupt(script(tmp_path, SIMULATE.format(jit=jit, hook=hook, throw=False)),
                               "^started", tmp_path)
    res = result_of(out)
    assert code == 0, err
    assert res["status"] == "interrupted" and res["k"] == 2 * stepper.CHUNK and res["same"]


@pytest.mark.parametrize("throw", [False, True])
def test_optimize_interrupted_reports_it_with_the_last_iterate(tmp_path, throw):
    """CasADi swallows the KeyboardInterrupt (IPOPT: NonIpopt_Exception_Thrown); optimize
    reports "interrupted", and its last iterate is the one of IPOPT's last logged
    iteration (its number and objective)."""
    code, out, err = interrupt(script(tmp_path, OPTIMIZE.format(throw=throw)),
                               r"^\s*1\s", tmp_path)
    res = result_of(out)
    assert code == 0, err
    assert res["how"] == ("raised" if throw else "returned")
    assert res["status"] == "interrupted" and res["success"] is False
    assert res["return_status"] == "NonIpopt_Exception_Thrown"
    assert "interrupted" in res["message"] and "boundary" not in res["message"]
    logged = [ITERATION.match(line) for line in out.splitlines()]
    last = [m for m in logged if m][-1]
    assert res["iterations"] == int(last.group(1)) >= 1
    assert res["cost"] == pytest.approx(float(last.group(2)), rel=1e-7, abs=1e-7)
    assert res["steps"] == 6000


def test_cli_optimize_interrupted_writes_the_last_iterate_and_exits_130(tmp_path):
    code, out, err = interrupt([sys.executable, "-m", "dmoc", "optimize", "knife-edge",
                                "--steps", "6000", "--verbose", "--out", "o"],
                               r"^\s*1\s", tmp_path)
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err and "boundary" not in err
    summary = json.loads((tmp_path / "o" / "knife_edge_summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["success"] is False
    assert summary["iterations"] >= 1
    assert dmoc.Trajectory.load(tmp_path / "o" / "knife_edge.npz").steps == 6000
    assert not list((tmp_path / "o").glob("*.png"))       # no plots: it stops at once


CLI = '''
import sys
{hook}
from dmoc.cli import main
sys.exit(main(["simulate", "knife-edge", "--steps", "1000000", "--out", "o"]))
'''


def test_cli_simulate_interrupted_writes_the_steps_so_far_and_exits_130(tmp_path):
    code, out, err = interrupt(script(tmp_path, CLI.format(hook=HOOK.format(chunks=2, hold=True))),
                               "^started", tmp_path)
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err
    summary = json.loads((tmp_path / "o" / "knife_edge_summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["completed_steps"] == 2 * stepper.CHUNK
    traj = dmoc.Trajectory.load(tmp_path / "o" / "knife_edge.npz")
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 10.0 / 10 ** 6)
    ref = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 1], steps=2 * stepper.CHUNK).trajectory
    assert np.array_equal(traj.q, ref.q) and np.array_equal(traj.p, ref.p)
    table = np.loadtxt(tmp_path / "o" / "knife_edge.csv", delimiter=",", skiprows=1)
    assert table.shape[0] == 2 * stepper.CHUNK + 1


def test_cli_interrupted_before_any_step_writes_nothing_and_exits_130(tmp_path):
    """A Ctrl-C outside a solve (here while the system is set up): one line, exit 130."""
    (tmp_path / "slow.py").write_text(
        "import time\nprint('started', flush=True)\ntime.sleep(600)\n")
    code, out, err = interrupt([sys.executable, "-m", "dmoc", "simulate", "slow.py:f",
                                "--out", "o"], "^started", tmp_path)
    assert code == 130 and "Traceback" not in err and "interrupted" in err
    assert not (tmp_path / "o").exists()    # nothing, not even the folder


@pytest.mark.parametrize("installed", ["custom", "default", "ignored"])
def test_a_solve_leaves_the_sigint_handler_it_found(installed):
    """`interrupt.watch` installs its own handler only for the IPOPT call: after a solve
    (and after one that raised), SIGINT's handler is the one in place before, the very
    object, whether a Python callable, Python's default or SIG_IGN."""
    from dmoc.optimal_control.solver import interrupt
    from dmoc.optimal_control import solve
    import dmoc.problems

    def custom(signum, frame):
        raise KeyboardInterrupt

    handler = {"custom": custom, "default": signal.default_int_handler, "ignored": signal.SIG_IGN}[installed]
    before = signal.signal(signal.SIGINT, handler)
    try:
        solve(dmoc.problems.knife_edge_parking(6))
        assert signal.getsignal(signal.SIGINT) is handler
        with pytest.raises(RuntimeError):
            with interrupt.watch() as seen:
                assert seen == [] and (signal.getsignal(signal.SIGINT) is handler) == (installed == "ignored")
                raise RuntimeError("inside the block")
        assert signal.getsignal(signal.SIGINT) is handler
    finally:
        signal.signal(signal.SIGINT, before)
