"""The atomic-write helper every writer uses."""

from __future__ import annotations

import os

import pytest

from generators.formats.atomic import atomic_path

from recordings import files_in


def test_atomic_file_failure_leaves_nothing_and_keeps_existing(tmp_path):
    target = tmp_path / "out.bin"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_bytes(b"partial")
        raise RuntimeError("boom")
    assert files_in(tmp_path) == []
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_bytes(b"new")
        raise RuntimeError("boom")
    assert files_in(tmp_path) == ["out.bin"] and target.read_bytes() == b"old"
    with atomic_path(target) as tmp:
        tmp.write_bytes(b"new")
    assert files_in(tmp_path) == ["out.bin"] and target.read_bytes() == b"new"


def test_atomic_directory_replaces_whole_folder_or_nothing(tmp_path):
    target = tmp_path / "seq"
    with pytest.raises(RuntimeError), atomic_path(target, directory=True) as tmp:
        (tmp / "a.txt").write_text("partial")
        raise RuntimeError("boom")
    assert files_in(tmp_path) == []
    with atomic_path(target, directory=True) as tmp:
        (tmp / "a.txt").write_text("one")
        (tmp / "stale.txt").write_text("only in the first version")
    with pytest.raises(RuntimeError), atomic_path(target, directory=True) as tmp:
        (tmp / "a.txt").write_text("two")
        raise RuntimeError("boom")
    assert files_in(target) == ["a.txt", "stale.txt"] and (target / "a.txt").read_text() == "one"
    with atomic_path(target, directory=True) as tmp:
        (tmp / "a.txt").write_text("two")
    # The new folder replaces the old one entirely (no stale files), and no backup is left behind.
    assert files_in(tmp_path) == ["seq"] and files_in(target) == ["a.txt"]
    assert (target / "a.txt").read_text() == "two"


def test_atomic_outputs_get_the_umask_mode_not_private(tmp_path):
    old = os.umask(0o022)
    try:
        with atomic_path(tmp_path / "f.bin") as tmp:
            tmp.write_bytes(b"x")
        with atomic_path(tmp_path / "d", directory=True) as tmp:
            (tmp / "a").write_text("x")
    finally:
        os.umask(old)
    assert (tmp_path / "f.bin").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "d").stat().st_mode & 0o777 == 0o755


def test_a_ctrl_c_inside_an_hdf5_callback_waits_for_check_and_the_file_stays_whole(tmp_path, monkeypatch):
    """h5py calls the sink from C: a KeyboardInterrupt raised there is swallowed or crashes the interpreter, so
    while an H5Output is open the signal is only recorded; check() raises it, and close() one that came after."""
    import signal

    import h5py
    import numpy as np

    from generators.formats import atomic
    from generators.formats.common import H5Output

    real, calls = atomic._pwrite, []

    def signalled_once(fd, data, offset):
        calls.append(offset)
        if len(calls) == 3:
            signal.raise_signal(signal.SIGINT)  # Python runs the handler right here, inside HDF5's call
        return real(fd, data, offset)

    monkeypatch.setattr(atomic, "_pwrite", signalled_once)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal
    try:
        data = np.arange(100_000, dtype=np.int64)
        out = H5Output(tmp_path / "f.h5")
        out.file["x"] = data
        out.file.flush()
        assert len(calls) >= 3
        with pytest.raises(KeyboardInterrupt):
            out.check()
        out.file["y"] = data
        signal.raise_signal(signal.SIGINT)
        with pytest.raises(KeyboardInterrupt):
            out.close()  # after the file is closed
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)
    with h5py.File(tmp_path / "f.h5", "r") as f:
        np.testing.assert_array_equal(f["x"][()], data)
        np.testing.assert_array_equal(f["y"][()], data)


def test_a_second_ctrl_c_while_one_is_held_interrupts_at_once(tmp_path):
    import signal

    from generators.formats.common import H5Output

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        out = H5Output(tmp_path / "f.h5")
        signal.raise_signal(signal.SIGINT)
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
        out.abort()  # nothing left to deliver
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)
