"""The shared-memory exchange of simulate_many's packed arrays (dmoc.batch.sharing): what
a worker writes the client reads back bit for bit; a file the client did not make safe is
refused; no file outlives its batch, whichever side stops first."""

import os

import numpy as np
import pytest

pytest.importorskip("distributed")

from dmoc.batch import sharing  # noqa: E402


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setattr(sharing, "FOLDER", str(tmp_path))
    return tmp_path


def _arrays():
    rng = np.random.default_rng(0)
    return {"t": rng.random(7), "q": rng.random((7, 3)), "lam": rng.random((6, 0)),
            "mu": rng.random((2, 1))}


def _write(share):
    """What a worker does with a chunk's arrays: (path, layout), or None (through Dask)."""
    file, arrays = sharing.SharedFile(share), _arrays()
    into = file.allocate({name: (a.shape, a.dtype) for name, a in arrays.items()})
    if into is None:
        return None
    for name, a in arrays.items():
        into[name][...] = a
    return (file.path, file.layout) if file.seal() else None


def test_what_a_worker_writes_the_client_reads_bit_for_bit(folder):
    with sharing.Exchange() as share:
        path, layout = _write((share[0], 0))
        assert oct(os.stat(path).st_mode & 0o777) == "0o600"
        back = sharing.read(path, layout)
        assert not os.path.exists(path)
        for name, a in _arrays().items():
            assert back[name].shape == a.shape and back[name].tobytes() == a.tobytes()
        back["q"][0, 0] = 5.0                    # a private copy-on-write page
    assert list(folder.iterdir()) == []


def test_small_chunks_and_workers_without_the_beacon_use_dask(folder):
    with sharing.Exchange() as share:
        assert _write(share) is None            # under MIN_BYTES
        assert _write((share[0] + "-other", 0)) is None
        assert _write(None) is None
    assert list(folder.iterdir()) == []


def test_no_folder_means_no_exchange(monkeypatch, tmp_path):
    monkeypatch.setattr(sharing, "FOLDER", str(tmp_path / "missing"))
    with sharing.Exchange() as share:
        assert share is None


def test_files_of_results_that_never_arrived_are_removed_at_the_end(folder):
    with sharing.Exchange() as share:
        _write((share[0], 0))
        _write((share[0], 0))
        assert len(list(folder.iterdir())) == 3              # the beacon and two chunks
    assert list(folder.iterdir()) == []


def test_a_chunk_written_after_its_batch_ended_removes_itself(folder, monkeypatch):
    with sharing.Exchange() as share:
        pass
    monkeypatch.setattr(sharing, "_own", lambda path: True)   # seen just before the end
    assert _write((share[0], 0)) is None
    assert list(folder.iterdir()) == []


def test_the_client_reads_nothing_outside_its_batch_files(folder, tmp_path_factory):
    elsewhere = tmp_path_factory.mktemp("elsewhere") / "dmoc-batch-x"
    elsewhere.write_bytes(b"")
    with pytest.raises(OSError, match="not a file of this user's batch"):
        sharing.read(str(elsewhere), {})
    assert elsewhere.exists()


@pytest.mark.parametrize("spoil", ["others may write", "wrong size"])
def test_the_client_refuses_a_file_it_cannot_trust(folder, spoil):
    with sharing.Exchange() as share:
        path, layout = _write((share[0], 0))
        if spoil == "others may write":
            os.chmod(path, 0o622)
        else:
            layout["t"] = (0, "<f8", (8,))
            layout["mu"] = (layout["mu"][0], "<f8", (3, 1))
        with pytest.raises(OSError, match="not a file of this user's batch"):
            sharing.read(path, layout)
        assert not os.path.exists(path)


def test_a_full_folder_means_dask_and_no_file(folder, monkeypatch):
    def full(fd, offset, size):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "posix_fallocate", full)
    with sharing.Exchange() as share:
        assert _write((share[0], 0)) is None
        assert len(list(folder.iterdir())) == 1                  # the beacon alone
    assert list(folder.iterdir()) == []
