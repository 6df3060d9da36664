"""The AKF's leak-aware event model (akf.reconstruct(leak_rate_hz=...)) against a DVS whose reference leaks, where
frames cannot correct the estimate: a static scene above the clip level, seen through saturated frames."""

import numpy as np
import pytest

import akf
import crf_models
import sim
from akf.noise import frame_measurement
from sim.errors import InvalidParameterError

LINEAR = crf_models.get("linear")
C = 0.2  # the ideal preset's contrast threshold (log)


@pytest.fixture(scope="module")
def leaking_static_scene():
    """2 s of a static 32x32 scene at twice the frames' clip level; an ideal DVS with a 2 Hz leak on every pixel
    (uniform random initial phase), so each pixel fires 4 ON leak events and no others."""
    h = w = 32
    dur = 2_000_000
    times = np.arange(0, dur + 1, 10_000)
    dvs = sim.DVSParams.preset("ideal", leak_hz=2.0, leak_spread=0.0)
    events = sim.DVSEmulator(h, w, dvs, seed=1).feed(np.full((times.size, h, w), 2.0), times)
    ts = np.arange(0, dur - 40_000, 40_000)
    frames = np.full((ts.size, h, w), 255, np.uint8)  # every frame saturated: one-sided measurements only
    return events, frames, ts, ts + 5_000, dvs.leak_hz


PARAMS = akf.AKFParams(i0=1e-4, max_variance=1e2)  # saturated frames: a negligible pull on estimates above them


def _above_clip(leak_rate_hz, scene, t_us=1_900_000):
    """(H * W,) log estimate at t_us minus the saturated frames' log measurement (the clip level)."""
    events, frames, ts, te, _ = scene
    out = akf.reconstruct(events, frames, ts, te, LINEAR, [t_us], params=PARAMS, leak_rate_hz=leak_rate_hz,
                          max_intensity=None)  # the estimate above the full well (x = 1) is what is measured
    clip = frame_measurement(np.ones(1), LINEAR, PARAMS).log[0]
    return np.log(out[0].astype(np.float64) + PARAMS.i0).ravel() - clip


def test_leak_events_carry_no_level_change_with_the_leak_rate_given(leaking_static_scene):
    events, _, _, _, leak_hz = leaking_static_scene
    assert np.all(events["p"] == 1) and events.size == 4 * 32 * 32
    # the paper's filter integrates every leak event: the estimate climbs by about leak_hz * C per second
    paper = _above_clip(0.0, leaking_static_scene)
    assert paper.mean() == pytest.approx(leak_hz * C * 1.9, rel=0.1)
    # leak-aware: later leak events carry exactly their drift (change 0); the first one removes the expected
    # pre-start drift, which leaves E[C - (C/2 + d - d^2 / 2C)] = C/6 for d ~ uniform[0, C) (the truth is static,
    # so a pixel's first event is its leak completing the unknown initial drift)
    aware = _above_clip(leak_hz, leaking_static_scene)
    assert aware.mean() == pytest.approx(C / 6, abs=0.01)
    assert aware.min() > -1e-6 and aware.max() < C / 2 + 1e-6


def test_first_event_adds_the_initial_drift_variance(leaking_static_scene):
    events, frames, ts, te, leak_hz = leaking_static_scene
    first = events[events["t"] > 200_000][0]  # well after the start: both filters sit at the clip level by then
    t, x, y = int(first["t"]), int(first["x"]), int(first["y"])
    assert not np.any((events["x"] == x) & (events["y"] == y) & (events["t"] < t))
    p = [akf.reconstruct(events, frames, ts, te, LINEAR, [t, t + 1], params=PARAMS, leak_rate_hz=rate,
                         return_variance=True)[1][:, y, x].astype(np.float64) for rate in (0.0, leak_hz)]
    assert p[0][0] == p[1][0]
    assert p[1][1] - p[0][1] == pytest.approx(C * C / 12, rel=1e-3)


def test_zero_leak_rate_is_the_papers_filter(leaking_static_scene):
    events, frames, ts, te, _ = leaking_static_scene
    times = [100_000, 900_000]
    default = akf.reconstruct(events, frames, ts, te, LINEAR, times)
    assert np.array_equal(default, akf.reconstruct(events, frames, ts, te, LINEAR, times, leak_rate_hz=0.0))


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), "2", True])
def test_leak_rate_is_validated(bad, leaking_static_scene):
    events, frames, ts, te, _ = leaking_static_scene
    with pytest.raises(InvalidParameterError, match="leak_rate_hz"):
        akf.reconstruct(events, frames, ts, te, LINEAR, [0], leak_rate_hz=bad)
    with pytest.raises(InvalidParameterError, match="leak_rate_hz"):
        akf.augmented_measurement(events, frames, ts, te, LINEAR, [0], [0], leak_rate_hz=bad)


def test_augmented_curve_is_leak_aware_too(leaking_static_scene):
    """A pure leak event after a pixel's first carries no change in the leak-aware curve (its drift since the
    previous event is a whole threshold), while the paper's curve steps by C."""
    events, frames, ts, te, leak_hz = leaking_static_scene
    x, y = int(events["x"][0]), int(events["y"][0])
    mine = events[(events["x"] == x) & (events["y"] == y)]
    t_second = int(mine["t"][1])
    times = [t_second - 1, t_second + 1]
    flat = y * 32 + x
    for rate, step in ((0.0, C), (leak_hz, 0.0)):
        aug = akf.augmented_measurement(events, frames, ts, te, LINEAR, times, [flat], params=PARAMS,
                                        leak_rate_hz=rate)
        assert aug.log[1, 0] - aug.log[0, 0] == pytest.approx(step, abs=1e-9)
