"""Test helpers: a small recording with every field set, exact comparison, and the tiny generated sequence."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

import sim
from generators.ahdr import AHDRConfig, generate_ahdr
from generators.formats.recording import Recording
from generators.scenes import MovingEdge
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


#: the tiny dataset: 16x20 pixels, 0.3 s, a moving edge under the davis346 DVS and the window CRF
TINY_H, TINY_W, TINY_DURATION_US = 16, 20, 300_000


def generate_tiny(path, seed: int = 0, crf: str = "window"):
    """One sequence of the tiny dataset (native, uncompressed), with HDR references at 50 Hz; returns path."""
    scene = MovingEdge(TINY_H, TINY_W, TINY_DURATION_US, speed_px_per_s=40.0)
    config = AHDRConfig(dvs=sim.DVSParams.preset("davis346"), crf=crf, reference_rate_hz=50.0, compression=None)
    generate_ahdr(scene, path, config, seed, progress=False)
    return path
