"""Shared synthetic recording for the format tests, and tests of the atomic-write helper."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from generators.formats.atomic import atomic_path
from generators.formats.recording import Recording
from sim import EVENT_DTYPE

H, W = 6, 8
# Times far from zero (about 34 hours) so that float32 seconds would lose microseconds: exactness is tested.
T0 = 123_456_789_012


def make_recording(*, bit_depth: int = 8, n_events: int = 3000, seed: int = 0) -> Recording:
    """A small recording with every field set: events (with equal-time ties), 4 frames with odd exposure
    lengths, 3 HDR reference frames spanning 1e-3..1e3, threshold maps, labels, a CRF and nested metadata."""
    rng = np.random.default_rng(seed)
    ev = np.zeros(n_events, dtype=EVENT_DTYPE)
    ev["t"] = T0 + np.sort(rng.integers(0, 2_500_000, n_events))
    ev["t"][10:13] = ev["t"][10]  # ties
    ev["x"] = rng.integers(0, W, n_events)
    ev["y"] = rng.integers(0, H, n_events)
    ev["p"] = rng.choice(np.array([-1, 1], np.int8), n_events)
    ev["x"][0], ev["y"][0] = W - 1, H - 1  # the far corner, for 1-based conversions
    f = 4
    t_start = T0 + np.array([0, 600_001, 1_200_000, 1_800_003], np.int64)
    t_end = t_start + np.array([5_001, 20_000, 1, 33_333], np.int64)
    t_mid = t_start + (t_end - t_start) // 2
    frames = rng.integers(0, 1 << bit_depth, (f, H, W)).astype(np.uint8 if bit_depth == 8 else np.uint16)
    frames[0, 0, 0], frames[0, 0, 1] = 0, (1 << bit_depth) - 1
    reference = (10.0 ** rng.uniform(-3, 3, (3, H, W))).astype(np.float32)
    return Recording(
        events=ev, height=H, width=W, frames=frames, frame_t_start_us=t_start, frame_t_mid_us=t_mid,
        frame_t_end_us=t_end, frame_bit_depth=bit_depth, reference=reference,
        reference_t_us=T0 + np.array([0, 1_000_000, 2_499_999], np.int64),
        crf={"name": "window", "params": {"low": 100.0, "high": 160.0}},
        threshold_maps=rng.uniform(0.15, 0.25, (2, H, W)).astype(np.float32),
        event_labels=rng.integers(0, 4, n_events).astype(np.uint8),
        metadata={"seed_entropy": 2**70 + 3, "config": {"dvs": {"pos_threshold": 0.2, "neg_threshold": 0.3}},
                  "versions": {"evsim": "0.1.0"}, "note": "unicode µs ✓"},
    )


def assert_recordings_equal(a: Recording, b: Recording, *, skip=()) -> None:
    """Field-by-field exact equality (arrays: same dtype class and values)."""
    for name in Recording.__dataclass_fields__:
        if name in skip:
            continue
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert x is not None and y is not None, name
            assert x.dtype == y.dtype, (name, x.dtype, y.dtype)
            np.testing.assert_array_equal(x, y, err_msg=name)
        else:
            assert x == y, name


def files_in(d: Path) -> list[str]:
    return sorted(os.listdir(d))


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
