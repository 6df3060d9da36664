"""The asynchronous Kalman smoother (akf.reconstruct_smoothed) against known truths: a pixel clipped at the start
and well exposed later is recovered over its clipped past; a static pixel clipped throughout keeps its bound
through event noise; the smoother equals the filter where nothing comes after."""

import numpy as np
import pytest

import akf
import crf_models
import sim

LINEAR = crf_models.get("linear")
C = 0.2  # log contrast threshold of the synthetic events
SHAPE = (8, 8)


def _uniform_events(times, polarities):
    """The same events at every pixel of SHAPE (a uniform scene: every pixel's neighbourhood counts as its own)."""
    h, w = SHAPE
    t = np.repeat(np.asarray(times, np.int64), h * w)
    y, x = np.divmod(np.tile(np.arange(h * w), len(times)), w)
    return sim.make_events(t, x, y, np.repeat(polarities, h * w))


def _frames(levels):
    """8-bit linear frames of uniform radiance `levels` (x units; clipped at 1), exposed 5 ms every 50 ms."""
    y = np.clip(np.round(np.asarray(levels, np.float64) * 255), 0, 255).astype(np.uint8)
    frames = np.broadcast_to(y[:, None, None], (len(levels), *SHAPE)).copy()
    ts = np.arange(len(levels), dtype=np.int64) * 50_000
    return frames, ts, ts + 5_000


def test_a_pixel_clipped_at_the_start_is_recovered_over_its_past():
    """Radiance 3 x (every frame clipped at 1 x) falls to 0.5 x by 9 OFF events of 0.2 between 110 and 130 ms,
    after which the frames measure it: the smoother carries the later frames' level back over the clipped past
    (within a threshold), the causal filter can only hold the clip bound there."""
    truth_early, truth_late = 0.5 * np.exp(9 * C), 0.5
    frames, ts, te = _frames([truth_early] * 3 + [truth_late] * 4)
    ev = _uniform_events(np.linspace(110_000, 130_000, 9).astype(np.int64), [-1] * 9)
    early = [20_000, 60_000, 100_000]
    smooth = akf.reconstruct_smoothed(ev, frames, ts, te, LINEAR, early, contrast=C, bit_depth=8)
    causal = akf.reconstruct(ev, frames, ts, te, LINEAR, early, contrast=C, bit_depth=8)
    np.testing.assert_allclose(np.log(smooth), np.log(truth_early), atol=C)
    assert np.all(causal <= 1.05)  # the filter sees only "at least 1 x" before 130 ms
    late = akf.reconstruct_smoothed(ev, frames, ts, te, LINEAR, [200_000, 300_000], contrast=C, bit_depth=8)
    np.testing.assert_allclose(late, truth_late, rtol=0.02)


def test_a_static_pixel_clipped_throughout_keeps_its_bound_through_event_noise():
    """Every frame clipped at 1 x, and shot-noise events of both polarities at 4 Hz per pixel: the smoother's output
    stays at or above the clip level at every time, and never above what the noise events themselves could carry
    a pixel to (the largest running net ON count of any pixel, times the threshold): the noise moves it, nothing
    accumulates beyond it."""
    rng = np.random.default_rng(0)
    frames, ts, te = _frames([2.0] * 8)
    h, w = SHAPE
    n = int(4 * 0.355 * h * w)
    t = np.sort(rng.integers(0, 355_000, n))
    x, y, p = rng.integers(0, w, n), rng.integers(0, h, n), rng.choice([-1, 1], n)
    ev = sim.make_events(t, x, y, p)
    times = np.arange(0, 355_000, 25_000)
    out = akf.reconstruct_smoothed(ev, frames, ts, te, LINEAR, times, contrast=C, bit_depth=8)
    assert np.all(np.isfinite(out))
    assert out.min() >= 1.0 - 1e-3  # a clipped frame says "at least 1 x"
    running = max(np.max(np.cumsum(p[(x == i) & (y == j)]), initial=0) for j in range(h) for i in range(w))
    assert out.max() <= np.exp(C * running) + 1e-3
    assert np.median(out) < np.exp(C)  # most pixels sit within a threshold of the bound


@pytest.mark.parametrize("smooth_range", [0.0, 4.0])
def test_the_smoother_equals_the_filter_after_the_last_frame(smooth_range):
    """After the last frame's mid-exposure no frame comes: the backward pass knows nothing and the smoother's output
    is the filter's, bit for bit."""
    rng = np.random.default_rng(1)
    frames, ts, te = _frames([0.3, 0.4, 0.35, 0.5])
    h, w = SHAPE
    n = 400
    ev = sim.make_events(np.sort(rng.integers(0, 155_000, n)), rng.integers(0, w, n), rng.integers(0, h, n),
                         rng.choice([-1, 1], n))
    params = akf.AKFParams(smooth_range=smooth_range)
    times = [153_000, 160_000]
    filtered = akf.reconstruct(ev, frames, ts, te, LINEAR, times, contrast=C, params=params)
    smoothed = akf.reconstruct_smoothed(ev, frames, ts, te, LINEAR, times, contrast=C, params=params)
    np.testing.assert_array_equal(smoothed, filtered)


def test_bad_options_are_refused_by_name():
    frames, ts, te = _frames([0.3, 0.4])
    ev = _uniform_events([10_000], [1])
    with pytest.raises(sim.InvalidParameterError, match="max_intensity"):
        akf.reconstruct_smoothed(ev, frames, ts, te, LINEAR, [20_000], max_intensity=-1.0)
    with pytest.raises(sim.InvalidParameterError, match="smoother_drift2"):
        akf.AKFParams(smoother_drift2=-1.0)
    with pytest.raises(sim.InvalidParameterError, match="clip_prior_variance"):
        akf.AKFParams(clip_prior_variance=0.0)  # a prior level of no uncertainty would outweigh every measurement


def test_an_estimate_run_out_of_float32_range_stays_finite():
    """Every frame clipped and a hot pixel firing 600 ON events at a nominal contrast of 1 (no flat field): its
    estimate runs out of float32's range in both passes; the smoother's and the filter's outputs are finite (the
    fusion multiplied an infinity by a zero weight: NaN), the hot pixel at the largest value, the others at the clip
    level."""
    frames = np.full((4, 12, 12), 255, np.uint8)
    ts = np.array([0, 50_000, 100_000, 150_000])
    ev = sim.make_events(np.arange(600) * 100 + 10_000, [6] * 600, [6] * 600, [1] * 600)
    params = akf.AKFParams(flat_field=False)
    for method in (akf.reconstruct, akf.reconstruct_smoothed):
        out = method(ev, frames, ts, ts + 5_000, LINEAR, [90_000, 150_000], contrast=1.0, params=params)
        assert np.isfinite(out).all(), method.__name__
        assert out[1, 6, 6] > 1e30
        np.testing.assert_allclose(np.delete(out[1].ravel(), 6 * 12 + 6), 1.0, rtol=1e-3)
