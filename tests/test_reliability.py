"""Reliability (issue 16): bad inputs get a clear error naming the argument, nothing wrong
passes as success, nothing computed is lost.

Oracles, none taken from the code under test: messages are checked by content (the
argument they must name and what they must say); files are damaged here by hand
(truncated, emptied, a byte flipped, written by plain numpy, random bytes); a failing
write is provoked by a writer that raises half-way; the saved trajectory must come back
bit for bit. The bad inputs listed in docs/verification.md ("Bad inputs") point here.
"""

import json
from dataclasses import fields

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc import batch, diagnostics
from dmoc.cli import main
from dmoc.discrete.rules import QuadratureRule
from dmoc.systems import knife_edge


@pytest.fixture(scope="module")
def disc():
    return dmoc.discretize(knife_edge(), 0.1)


@pytest.fixture(scope="module")
def traj(disc):
    return dmoc.simulate(disc, q0=[0, 0, 0.3], v0=[np.cos(0.3), np.sin(0.3), 1.0], steps=6,
                         controls=np.random.default_rng(1).normal(size=(6, 2))).trajectory


def same(a, b):
    return all(np.array_equal(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))


def small_trajectory(**changes):
    """Trajectory(...) of 2 steps, n = 1, with some fields replaced."""
    kwargs = dict(t=[0.0, 0.5, 1.0], q=[[0.0], [1.0], [2.0]], p=[[0.0]] * 3, lam=[[], []],
                  u=[[1.0], [2.0]], h=0.5, variant="+")
    return dmoc.Trajectory(**{**kwargs, **changes})


# ---------------------------------------------------------------------------------------
# The taxonomy: input errors are DmocError and ValueError/TypeError


def test_input_errors_are_dmoc_errors_and_builtin_errors(disc):
    with pytest.raises(dmoc.InputError, match="`steps`") as value:
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=0)
    with pytest.raises(dmoc.InputTypeError, match="`q0`") as kind:
        dmoc.simulate(disc, q0="abc", v0=[1, 0, 0], steps=2)
    assert isinstance(value.value, (dmoc.DmocError, ValueError))
    assert isinstance(kind.value, dmoc.DmocError) and isinstance(kind.value, TypeError)
    assert issubclass(dmoc.TrajectoryFileError, dmoc.InputError)
    assert not issubclass(dmoc.SolverError, (ValueError, TypeError))


# ---------------------------------------------------------------------------------------
# Arrays at the boundary: ragged, symbolic, complex, strings, NaN and bools where only
# None means "free"


def test_ragged_controls_are_named(disc):
    with pytest.raises(dmoc.InputError, match="`controls` .*ragged"):
        dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=3, controls=[[0, 0], [0], [0, 0]])


def test_symbolic_start_is_named(disc):
    with pytest.raises(dmoc.InputTypeError, match="`q0` .*symbolic SX.*evaluate"):
        dmoc.simulate(disc, q0=ca.SX.sym("q", 3), v0=[1, 0, 0], steps=3)


def test_complex_start_is_refused(disc):
    with pytest.raises(dmoc.InputTypeError, match="`q0` .*complex128"):
        dmoc.simulate(disc, q0=[0, 0, 1j], v0=[1, 0, 0], steps=3)


@pytest.mark.parametrize("name", ["q_goal", "q_start", "v_goal", "v_start"])
@pytest.mark.parametrize("entry, error, words", [
    (np.nan, dmoc.InputError, "NaN; only None leaves an entry free"),
    (True, dmoc.InputTypeError, "entry 1 is True"),
    ("0.5", dmoc.InputTypeError, "entry 1 is '0.5'"),
])
def test_only_none_is_free_in_boundary_data(disc, name, entry, error, words):
    data = {"q_start": [0.0, 0.0, 0.0], "q_goal": [0.0, 1.0, 0.0]}
    data[name] = [0.0, entry, 0.0]
    with pytest.raises(error, match=f"`{name}`.*{words}"):
        dmoc.OptimalControlProblem(disc, 5, **data)


def test_bounds_refuse_nan_and_bools(disc):
    with pytest.raises(dmoc.InputTypeError, match="`control_bounds`.*True"):
        dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                   control_bounds=([True, 0.0], [1.0, 1.0]))


def test_none_still_means_free(disc):
    problem = dmoc.OptimalControlProblem(disc, 5, q_start=[0, 0, 0], q_goal=[0, 1, None])
    assert np.isnan(problem.q_goal[2]) and np.isfinite(problem.q_goal[:2]).all()


def test_empty_quadrature_rule_is_refused():
    with pytest.raises(ValueError, match="`points` must be"):
        QuadratureRule("empty", 2)


# ---------------------------------------------------------------------------------------
# Trajectory: the time grid must be the grid of h; real numbers only


@pytest.mark.parametrize("t", [[0.0, 1.0, 2.0], [0.0, 0.5, 1.5], [0.0, 0.5, np.nan]])
def test_time_grid_must_match_h(t):
    with pytest.raises(dmoc.InputError, match="`t`"):
        small_trajectory(t=t)


def test_time_grids_of_h_are_accepted():
    N, h = 10 ** 5, 1e-3
    q = np.zeros((N + 1, 1))
    for t in (np.linspace(0.0, N * h, N + 1), np.r_[0.0, np.cumsum(np.full(N, h))],
              7.25 + h * np.arange(N + 1)):
        assert dmoc.Trajectory(t, q, q, np.zeros((N, 0)), np.zeros((N, 0)), h, "+").steps == N


@pytest.mark.parametrize("name, value", [
    ("q", [[0.0], [1.0 + 1e-3j], [2.0]]),
    ("p", np.zeros((3, 1), dtype=complex)),
    ("u", [[1.0], [2.0j]]),
    ("q", [["a"], ["b"], ["c"]]),
    ("q", [[0.0], [1.0, 2.0], [2.0]]),
    ("lam", [[True], [False]]),
])
def test_trajectory_arrays_must_be_real(name, value):
    with pytest.raises((dmoc.InputError, dmoc.InputTypeError), match=f"`{name}`"):
        small_trajectory(**{name: value})


@pytest.mark.parametrize("nodes", [(2.0,), (0.5, 0.5), (), (np.nan,)])
def test_control_nodes_must_be_distinct_step_times(nodes):
    with pytest.raises(dmoc.InputError, match="`control_nodes`"):
        small_trajectory(u=[[1.0, 2.0], [2.0, 3.0]], control_nodes=nodes)


# ---------------------------------------------------------------------------------------
# Trajectory files: atomic writes, loads that say what is wrong, never unpickle


def test_failed_overwrite_keeps_the_previous_file(traj, tmp_path, monkeypatch):
    path = tmp_path / "run.npz"
    traj.save(path)

    def half_then_disk_full(file, **arrays):
        file.write(b"PK\x03\x04" + b"\0" * 1000)     # a partial archive, then the failure
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez", half_then_disk_full)
    with pytest.raises(OSError, match="No space left"):
        small_trajectory().save(path)
    monkeypatch.undo()
    assert same(dmoc.Trajectory.load(path), traj)
    assert [p.name for p in tmp_path.iterdir()] == ["run.npz"]      # no temporary left


def test_save_replaces_and_keeps_permissions_of_a_plain_write(traj, tmp_path):
    path = tmp_path / "run.npz"
    small_trajectory().save(path)
    traj.save(path)
    assert same(dmoc.Trajectory.load(path), traj)
    plain = tmp_path / "plain"
    plain.write_bytes(b"")
    assert path.stat().st_mode == plain.stat().st_mode


def _damaged(traj, tmp_path, how):
    path = tmp_path / "damaged.npz"
    traj.save(path)
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "flipped byte":
        i = data.index(b"\x93NUMPY", 200) + 140      # inside the data of an array
        path.write_bytes(data[:i] + bytes([data[i] ^ 0xFF]) + data[i + 1:])
    elif how == "random bytes":
        path.write_bytes(np.random.default_rng(0).bytes(2000))
    elif how == "a .npy file":
        np.save(path.with_suffix(".npy"), traj.q)
        path.write_bytes(path.with_suffix(".npy").read_bytes())
    elif how == "foreign archive":
        np.savez(path, a=np.zeros(3))
    elif how == "pickled objects":
        values = {f.name: np.asarray(getattr(traj, f.name)) for f in fields(traj)}
        np.savez(path, **{**values, "q": np.array([object()] * 3, dtype=object)})
    elif how == "extra field":
        values = {f.name: np.asarray(getattr(traj, f.name)) for f in fields(traj)}
        np.savez(path, **values, payload=np.zeros(2))
    elif how == "inconsistent shapes":
        values = {f.name: np.asarray(getattr(traj, f.name)) for f in fields(traj)}
        np.savez(path, **{**values, "p": values["p"][:-1]})
    elif how == "h of two values":
        values = {f.name: np.asarray(getattr(traj, f.name)) for f in fields(traj)}
        np.savez(path, **{**values, "h": np.array([0.1, 0.2])})
    return path


@pytest.mark.parametrize("how, reason", [
    ("truncated", "truncated or corrupted"), ("empty", "it is empty"),
    ("flipped byte", "truncated or corrupted"), ("random bytes", "not an .npz"),
    ("a .npy file", "not an .npz"), ("foreign archive", "lacks the fields"),
    ("pickled objects", "truncated or corrupted.*allow_pickle"),
    ("extra field", "does not have: \\['payload'\\]"),
    ("inconsistent shapes", "do not form a trajectory: `p` must have shape"),
    ("h of two values", "`h` must be a single value"),
])
def test_damaged_file_is_not_a_valid_trajectory(traj, tmp_path, how, reason):
    path = _damaged(traj, tmp_path, how)
    with pytest.raises(dmoc.TrajectoryFileError, match=f"not a valid dmoc trajectory file.*{reason}"):
        dmoc.Trajectory.load(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.npz"):
        dmoc.Trajectory.load(tmp_path / "nothing.npz")


# ---------------------------------------------------------------------------------------
# Diagnostics, Dirac structure, principle: unknown variants and wrong objects


def test_unknown_variants_are_refused(disc):
    with pytest.raises(dmoc.InputError, match=r"`variant` must be one of '\+', '-'; got 'plus'"):
        dmoc.dirac.dirac_differential(disc, "plus")
    symbols = [ca.SX.sym(name, 3, 3) for name in ("q", "q_aux", "p", "s")]
    with pytest.raises(dmoc.InputError, match=r"`variant` must be one of '\+', '-'; got 'x'"):
        dmoc.action_sum(disc, "x", *symbols, 0.1)


def test_diagnostics_name_wrong_objects(disc, traj):
    with pytest.raises(dmoc.InputTypeError, match="`disc` must be a Discretization; got str"):
        dmoc.dirac.dirac_differential("disc", "+")
    with pytest.raises(dmoc.InputTypeError, match="`problem` must be an OptimalControlProblem"):
        diagnostics.replay_error("problem", None)
    problem = dmoc.OptimalControlProblem(disc, 6, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.InputTypeError, match="`result.trajectory` must be a Trajectory"):
        diagnostics.replay_error(problem, traj)
    with pytest.raises(dmoc.InputError, match="`tol_rank` must be finite and positive"):
        dmoc.dirac.dirac_defect(disc, traj, tol_rank=-1.0)
    with pytest.raises(dmoc.InputTypeError, match="`disc` must be a Discretization"):
        diagnostics.symplecticity_defect(knife_edge(), [0, 0, 0], [0, 0, 0])


# ---------------------------------------------------------------------------------------
# Batch: IPOPT options checked before anything is submitted


@pytest.mark.parametrize("options, words", [
    ({"max_iter": None}, r"`options\['max_iter'\]` must be a number, a string or a bool; got None"),
    ({3: 1}, "string keys .*got the key 3"),
    ({"tol": [1e-8]}, r"`options\['tol'\]`"),
    (["max_iter", 5], "must be a dict of IPOPT options; got list"),
])
def test_batch_checks_ipopt_options(disc, options, words):
    problem = dmoc.OptimalControlProblem(disc, 4, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.InputTypeError, match=words):
        batch.optimize_many([problem], options=options, client="tcp://127.0.0.1:1")


# ---------------------------------------------------------------------------------------
# Faults: a solver stopped at its iteration limit keeps its last iterate


def test_iteration_limit_keeps_the_last_iterate(disc, tmp_path):
    problem = dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.SolverError, match="Maximum_Iterations_Exceeded after 3 iterations") as info:
        dmoc.optimize(problem, options={"max_iter": 3})
    result = info.value.result
    assert result.success is False and result.stats["iterations"] == 3
    x = problem.x_layout
    np.testing.assert_array_equal(result.trajectory.q, x.unpack(result.x, "q").T)
    assert np.isfinite(result.trajectory.q).all() and result.trajectory.steps == 10
    result.trajectory.save(tmp_path / "last.npz")
    assert same(dmoc.Trajectory.load(tmp_path / "last.npz"), result.trajectory)
    # The last iterate is a warm start that finishes the job.
    assert dmoc.optimize(problem, guess=result.trajectory).success


# ---------------------------------------------------------------------------------------
# The command line: every bad argument exits 2 with one line, no traceback

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
    (["simulate", "knife-edge", "--controls", "{f}/objects.npy"], "--controls", "allow_pickle"),
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
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

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
    # written before its table, is not in place either (tests/test_cli_files.py)
    assert dmoc.Trajectory.load(tmp_path / "knife_edge.npz").steps == 5
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
