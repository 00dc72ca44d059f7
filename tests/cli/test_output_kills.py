"""A run's output set is replaced in one atomic step (`dmoc._util.file_set`, docs/cli.md,
"Output files"): the process is killed (SIGKILL) at each os call of the replacement in
turn, from writing the new files to the last clean-up, and the folder then shows the old
set or the new one, byte for byte; the next run then shows its own set and keeps nothing
else, and the user's files stay. The start is either a set written by this layout or one
written as plain files (by a dmoc before it)."""

import os
import signal

import pytest

from dmoc._util import file_set, files

OLD = {"run.npz": b"old trajectory", "run.csv": b"old table", "run.gif": b"old animation"}
NEW = {"run.npz": b"new trajectory", "run.csv": b"new table", "run_path.png": b"new plot"}
NEXT = {"run.npz": b"next trajectory", "run.csv": b"next table"}
NAMES = sorted({*OLD, *NEW, *NEXT})


def write(out, contents):
    """One run named "run" writing `contents` ({file: bytes}) into `out`."""
    with files.staged_run(out, "run", NAMES) as stage:
        for name, data in contents.items():
            with files.atomic_write(stage / name) as file:
                file.write(data)


def shown(out):
    """{file: bytes} of the run's files a user sees in `out` (links followed)."""
    return {n: (out / n).read_bytes() for n in NAMES if (out / n).exists()}


class Killing:
    """`os`, killing this process with SIGKILL at its `at`-th call."""

    def __init__(self, at):
        self.at, self.calls = at, 0

    def __getattr__(self, name):
        real = getattr(os, name)
        if not callable(real) or isinstance(real, type):
            return real

        def counted(*args, **kwargs):
            self.calls += 1
            if self.calls == self.at:
                os.kill(os.getpid(), signal.SIGKILL)
            return real(*args, **kwargs)
        return counted


def killed_run(out, at):
    """Write NEW into `out` in a forked child killed at its `at`-th os call of the writing;
    whether it was killed (False: it finished first)."""
    pid = os.fork()
    if pid == 0:                # the child: never back into pytest
        try:
            files.os = file_set.os = Killing(at)
            write(out, NEW)
        finally:
            os._exit(0)
    _, status = os.waitpid(pid, 0)
    return os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL


@pytest.mark.parametrize("start", ["this layout", "plain files"])
def test_a_kill_at_each_step_leaves_the_old_set_or_the_new(tmp_path, start):
    outcomes = []
    for at in range(1, 500):
        out = tmp_path / str(at)
        out.mkdir()
        (out / "notes.txt").write_bytes(b"the user's")
        if start == "plain files":
            for name, data in OLD.items():
                (out / name).write_bytes(data)
        else:
            write(out, OLD)
        if not killed_run(out, at):
            assert shown(out) == NEW
            break
        outcomes.append("old" if shown(out) == OLD else "new" if shown(out) == NEW else shown(out))
        assert outcomes[-1] in ("old", "new"), (at, outcomes[-1])
        files._SWEPT.clear()                        # the next run: a new process, which
        write(out, NEXT)                            # sweeps the killed one's temporaries
        assert shown(out) == NEXT and (out / "notes.txt").read_bytes() == b"the user's"
        hidden = out / file_set.hidden_folder("run")
        assert sorted(p.name for p in hidden.iterdir())[0] == file_set.CURRENT
        assert len(list(hidden.iterdir())) == 2     # current and its version only
        assert sorted(p.name for p in out.iterdir()) == sorted(
            ["notes.txt", hidden.name, *NEXT])       # no temporary, no dangling link
    assert "old" in outcomes and "new" in outcomes and len(outcomes) > 10
