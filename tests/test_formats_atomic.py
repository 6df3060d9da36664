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
