"""Refactoring guard: the DVS emulator's events and the reconstructions are bit-identical to stored hashes on small
cases of the bench inputs (bench/bench_dvs.py's moving texture, bench/bench_akf.py's random-walk events and window
CRF frames).

The hashes pin the output of this machine kind (x86-64, numba's host-tuned code; the AKF kernels use fastmath): a
change that alters any event time, pixel, polarity, label or output bit fails here. When a change is meant to alter
the output, its commit says so and replaces the hashes with the ones the failure prints.
"""

import hashlib
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import akf
import crf_models
import sim

BENCH = Path(__file__).resolve().parents[1] / "bench"


def _bench_module(name: str):
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.descr, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


DVS_HASHES = {"ideal": "ec5c723727f83e01", "davis346": "a10a66d93a99947b", "noisy": "992e09773f10958a"}
AKF_HASHES = {"akf": "99eb95d8da4ab4d3", "cf": "64e1a6cef77558de", "akf_leak": "6811bb3d1287e039"}


@pytest.mark.parametrize("preset", sorted(DVS_HASHES))
def test_dvs_events_match_stored_hashes(preset):
    scene = _bench_module("bench_dvs").TexturedScene(40, 56, speed_px=0.3)
    frames = scene.frames(0, 60)
    times = np.arange(60, dtype=np.int64) * 1000
    params = sim.DVSParams.preset(preset)
    stack = sim.DVSEmulator(40, 56, params, seed=7, return_labels=True)
    events, labels = stack.feed(frames, times)
    by_frame = sim.DVSEmulator(40, 56, params, seed=7, return_labels=True)
    parts = [by_frame.feed(frames[k:k + 1], times[k:k + 1]) for k in range(60)]
    assert _digest(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])) == \
        _digest(events, labels)
    assert events.size > 1000
    assert _digest(events, labels) == DVS_HASHES[preset], f"{preset}: {_digest(events, labels)}"


def test_reconstructions_match_stored_hashes():
    bench = _bench_module("bench_akf")
    crf = crf_models.get("window")
    events = bench.random_walk_events(2e6, 0.2, walkers=500, seed=3)
    frames, ts, te = bench.frames_and_times(0.2, crf)
    out_times = np.arange(0, 190_001, 20_000)
    got = {"akf": akf.reconstruct(events, frames, ts, te, crf, out_times, return_variance=True),
           "cf": akf.complementary_filter(events, frames, ts, te, crf, out_times),
           "akf_leak": akf.reconstruct(events, frames, ts, te, crf, out_times, leak_rate_hz=0.1, max_intensity=None)}
    digests = {k: _digest(*(v if isinstance(v, tuple) else (v,))) for k, v in got.items()}
    assert digests == AKF_HASHES, digests
