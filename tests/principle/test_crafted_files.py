"""Crafted trajectory and result files (docs/errors.md, "Files"): each refused with a
TrajectoryFileError naming the field or the member, never a raw NumPy, JSON or zip error,
a hang or an allocation of what the file declares; the command line's ``--controls``
refuses a crafted .npy the same way. The files are written here with zipfile and NumPy's
.npy format directly, not with dmoc's writer."""

import io
import json
import os
import signal
import struct
import tracemalloc
import zipfile

import numpy as np
import pytest

import dmoc
from dmoc.cli import arguments
from dmoc.errors import TrajectoryFileError

GOOD = {"t": np.array([0.0, 0.1]), "q": np.zeros((2, 3)), "p": np.zeros((2, 3)),
        "lam": np.zeros((1, 2)), "u": np.zeros((1, 2)), "h": np.array(0.1),
        "variant": np.array("+"), "mu": np.zeros(2), "s": np.zeros((1, 0)),
        "control_nodes": np.array([0.5]), "stage_nodes": np.zeros(0),
        "result_cost": np.array(1.5), "result_success": np.array(True),
        "result_status": np.array("Solve_Succeeded"), "result_message": np.array("done"),
        "result_stats": np.array(json.dumps({"iterations": 3})),
        "result_structure": np.array("key"), "result_x": np.zeros(4),
        "result_q_ref": np.zeros(3)}


def npy(array):
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, np.asanyarray(array), allow_pickle=True)
    return buffer.getvalue()


def archive(path, fields, compression=zipfile.ZIP_STORED, extra=()):
    """Write `fields` ({name: array}) as members name.npy, then the (name, bytes) `extra`."""
    with zipfile.ZipFile(path, "w", compression=compression) as zf:
        for name, value in fields.items():
            zf.writestr(name + ".npy", npy(value))
        for name, data in extra:
            zf.writestr(name, data)
    return path


def test_the_good_file_loads(tmp_path):
    """The control: the fields above, written this way, are a result."""
    result = dmoc.OptimizationResult.load(archive(tmp_path / "r.npz", GOOD))
    assert (result.success, result.stats, result.cost) == (True, {"iterations": 3}, 1.5)


VERDICT = {"status": "passed", "replay_q": 0.0, "replay_p": 0.0, "replay_step": -1,
           "velocity_jump": 0.1, "jump_step": 1, "jump_coordinate": "x",
           "path_violation": 0.0, "path_step": -1, "path_row": -1}

CRAFTED = {
    "success as the text 'False'": ({"result_success": np.array("False")},
                                    r"`result_success` must be a bool .*got dtype <U5"),
    "stats a JSON list": ({"result_stats": np.array("[1, 2]")},
                          r"`result_stats` must be a JSON object; got a JSON list"),
    "stats bad JSON": ({"result_stats": np.array("{oops")},
                       r"`result_stats` must be a JSON object; got JSONDecodeError"),
    "stats nested past the recursion limit": ({"result_stats": np.array("[" * 200000)},
                                              r"`result_stats` .*RecursionError"),
    "status of shape (2,)": ({"result_status": np.array(["a", "b"])},
                             r"`result_status` must be a single value; got shape \(2,\)"),
    "complex x": ({"result_x": np.zeros(4, complex)},
                  r"`result_x` must be a real vector .*complex128"),
    "q_ref of another size": ({"result_q_ref": np.zeros(2)}, r"`result_q_ref` must be a real "
                              r"vector of shape \(n,\) = \(3,\)"),
    "unknown verdict keys": ({"result_verdict": np.array(json.dumps({**VERDICT, "extra": 1}))},
                             r"`result_verdict` must have the keys .*unknown keys \['extra'\]"),
    "a verdict step as text": ({"result_verdict": np.array(json.dumps({**VERDICT, "jump_step": "1"}))},
                               r"`result_verdict` must have 'jump_step' an integer"),
    "an unknown result field": ({"result_extra": np.array(1.0)},
                                r"holds result fields a result does not have: \['extra'\]"),
    "an object array": ({"result_x": np.array([None, 1], dtype=object)},
                        r"member 'result_x.npy' holds Python objects"),
    "complex h": ({"h": np.array(0.1 + 1j)}, r"`h` must be a real number; got dtype complex"),
    "variant a number": ({"variant": np.array(1.0)}, r"`variant` must be text; got dtype float64"),
    "complex q": ({"q": np.zeros((2, 3), complex)}, r"`q`"),
}


@pytest.mark.parametrize("case", CRAFTED)
def test_a_crafted_field_is_refused_naming_it(tmp_path, case):
    change, message = CRAFTED[case]
    path = archive(tmp_path / "r.npz", {**GOOD, **change})
    with pytest.raises(TrajectoryFileError, match=message):
        dmoc.OptimizationResult.load(path)


def test_a_member_named_twice_is_refused(tmp_path):
    path = tmp_path / "r.npz"
    with pytest.warns(UserWarning, match="Duplicate name"):
        archive(path, GOOD, extra=[("result_success.npy", npy(np.array(False)))])
    for load in (dmoc.OptimizationResult.load, dmoc.Trajectory.load):
        with pytest.raises(TrajectoryFileError, match=r"members \['result_success.npy'\] more than once"):
            load(path)


def declared(shape, data=b""):
    """.npy bytes whose header declares `shape` of float64, followed by `data` only."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False,
                                                  "shape": shape})
    return buffer.getvalue() + data


def test_a_declared_shape_of_1e12_is_refused_before_allocating(tmp_path):
    path = archive(tmp_path / "r.npz", {k: v for k, v in GOOD.items() if k != "q"},
                   extra=[("q.npy", declared((10**12, 3), bytes(48)))])
    with pytest.raises(TrajectoryFileError, match=r"member 'q.npy' declares shape \(1000000000000, 3\)"):
        dmoc.Trajectory.load(path)


def test_a_small_file_declaring_2_4_gb_is_refused_without_allocating(tmp_path):
    """A deflated member of 1 MiB of zeros whose zip directory (and .npy header) declare
    2.4 GB, as a compression bomb would: refused from the directory, before inflating."""
    size = 2_400_000_000
    path = tmp_path / "bomb.npz"
    archive(path, {k: v for k, v in GOOD.items() if k != "q"}, zipfile.ZIP_DEFLATED,
            extra=[("q.npy", declared((size // 24, 3), bytes(2**20)))])
    data = bytearray(path.read_bytes())
    for signature, offset in ((b"PK\x03\x04", 22), (b"PK\x01\x02", 24)):   # uncompressed size
        at = data.rfind(signature)          # the last member's local and central headers
        assert data[at + 30 if signature == b"PK\x03\x04" else at + 46:].startswith(b"q.npy")
        header = len(declared((size // 24, 3)))
        struct.pack_into("<I", data, at + offset, size + header)
    path.write_bytes(bytes(data))
    assert path.stat().st_size < 3 * 2**20
    tracemalloc.start()
    with pytest.raises(TrajectoryFileError, match=r"declare 24000\d{5} bytes in all, more than"):
        dmoc.Trajectory.load(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50 * 2**20


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe.npz"
    os.mkfifo(fifo)
    signal.signal(signal.SIGALRM, lambda *_: pytest.fail("Trajectory.load blocked on a FIFO"))
    signal.alarm(20)
    try:
        with pytest.raises(TrajectoryFileError, match="it is a FIFO"):
            dmoc.Trajectory.load(fifo)
    finally:
        signal.alarm(0)


def test_cli_controls_of_a_declared_shape_of_1e12_is_a_usage_error(tmp_path):
    path = tmp_path / "u.npy"
    path.write_bytes(declared((10**12, 2), bytes(16)))
    with pytest.raises(arguments.UsageError, match=r"--controls.*declares shape \(1000000000000, 2\)"):
        arguments.load_controls(str(path), ["x", "y", "theta"], 2)
