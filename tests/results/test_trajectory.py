"""Trajectory: its fields are checked (shapes, real numbers, the time grid of h, control
nodes), it owns its arrays, and its files round-trip bit for bit, are written atomically
and, when damaged, are refused saying what is wrong (never unpickled).

Oracles, none taken from the code under test: save/load must give back every field bit
for bit; files are damaged here by hand (truncated, emptied, a byte flipped, written by
plain numpy, random bytes); a failing write is provoked by a writer that raises half-way;
messages by content."""

from dataclasses import fields

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.problems import knife_edge_parking
from dmoc.systems import knife_edge

from tests._helpers import GOOD, same


@pytest.mark.parametrize("field, value", [("lam", np.zeros((2, 1))), ("u", np.zeros((2, 2))),
                                          ("s", np.zeros((4, 1)))])
def test_trajectory_names_misshaped_fields(field, value):
    data = dict(t=np.arange(4.0), q=np.zeros((4, 3)), p=np.zeros((4, 3)), lam=np.zeros((3, 1)),
                u=np.zeros((3, 2)), h=1.0, variant="+")
    data[field] = value
    with pytest.raises(ValueError, match=f"`{field}`"):
        dmoc.Trajectory(**data)


def test_trajectory_rejects_bad_step():
    with pytest.raises(ValueError, match="`h`"):
        dmoc.Trajectory([0, 1], [[0.0], [1.0]], [[0.0], [0.0]], [], [], -1.0, "+")


def test_trajectory_owns_its_arrays():
    result = dmoc.optimize(knife_edge_parking(20))
    before = result.x.copy()
    result.trajectory.q[:] = 7.0
    assert np.array_equal(result.x, before)


def small_trajectory(**changes):
    """Trajectory(...) of 2 steps, n = 1, with some fields replaced."""
    kwargs = dict(t=[0.0, 0.5, 1.0], q=[[0.0], [1.0], [2.0]], p=[[0.0]] * 3, lam=[[], []],
                  u=[[1.0], [2.0]], h=0.5, variant="+")
    return dmoc.Trajectory(**{**kwargs, **changes})


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


def assert_same_trajectory(a, b):
    for f in fields(dmoc.Trajectory):
        x, y = getattr(a, f.name), getattr(b, f.name)
        assert type(x) is type(y), f.name
        assert np.array_equal(x, y), f.name
        assert np.asarray(x).shape == np.asarray(y).shape, f.name


@pytest.mark.parametrize("variant", ["+", "-"])
@pytest.mark.parametrize("with_constraints", [True, False])
def test_trajectory_round_trip(tmp_path, variant, with_constraints):
    rng = np.random.default_rng(5)
    if with_constraints:               # m = 1, n_u = 2, random controls
        d, kw = dmoc.discretize(knife_edge(incline=0.2), 0.07), dict(
            q0=GOOD["q0"], v0=GOOD["v0"], controls=rng.normal(size=(12, 2)))
    else:                              # m = 0, n_u = 0: empty lam, u, mu
        d = dmoc.discretize(dmoc.MechanicalSystem(
            lambda q, v: 0.5 * ca.dot(v, v) + ca.cos(q[0]), 2), 0.07)
        kw = dict(q0=[0.3, 0.1], v0=[0.2, -0.4])
    traj = dmoc.simulate(d, steps=12, variant=variant, **kw).trajectory
    path = tmp_path / "traj.npz"
    traj.save(path)
    back = dmoc.Trajectory.load(path)
    assert_same_trajectory(traj, back)
    assert back.steps == 12 and back.variant == variant


def test_trajectory_round_trip_path_without_suffix(tmp_path):
    """save(path) then load(path) with the same path must round-trip; np.savez appends
    ".npz" to a path without that suffix, so save must write (or load read) that file."""
    d = dmoc.discretize(knife_edge(), 0.1)
    traj = dmoc.simulate(d, **GOOD).trajectory
    traj.save(tmp_path / "run")
    assert_same_trajectory(traj, dmoc.Trajectory.load(tmp_path / "run"))


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
    ("pickled objects", "member 'q.npy' holds Python objects .*never unpickles"),
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
