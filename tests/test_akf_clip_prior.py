"""The clip prior (akf.clip_prior): pixels clipped since the first frame take the level their measured clipped
neighbours show beyond the clip, against known truths."""

import dataclasses

import numpy as np
import pytest

import akf
import crf_models
import sim
from akf.clip_prior import MIN_SAMPLE, conditional_median, fill_unmeasured
from akf.smoothing import LARGEST

LINEAR = crf_models.get("linear")


def test_conditional_median_is_the_median_of_the_sample_beyond_each_bound():
    rng = np.random.default_rng(0)
    sample = rng.normal(size=101)
    bounds = np.concatenate([rng.normal(size=200), [sample.max() + 1.0, sample.min() - 1.0]])
    got = conditional_median(bounds, sample)
    for b, g in zip(bounds, got):
        beyond = np.sort(sample[sample >= b])
        expected = beyond[beyond.size // 2] if beyond.size else b  # the upper median of an even count
        assert g == expected
    assert np.all(got >= bounds)
    order = np.argsort(bounds)
    assert np.all(np.diff(got[order]) >= 0)  # the order of the bounds is kept
    np.testing.assert_array_equal(conditional_median(bounds, []), bounds)  # no sample: the bound stays


def test_fill_unmeasured_takes_the_measured_level_beyond_each_side():
    """A picture with a highlight at 3 x (clip at 1) and a shadow at 0.01 x (clip at 0.1): the measured pixels of
    each know their level, the never-measured ones sit at the clip level (a bound). Each takes the measured level
    of its side; a measured pixel, a pixel inside the frame's range and a side with too small a sample keep theirs."""
    i0 = 1e-3
    img = np.full((10, 10), 0.5, np.float32)
    side = np.zeros((10, 10))
    measured = np.ones((10, 10), bool)
    img[:5], side[:5] = 3.0, 1.0  # highlight: measured rows 0-2 at the truth, rows 3-4 never measured, at the clip
    img[3:5], measured[3:5] = 1.0, False
    img[5:], side[5:] = 0.01, -1.0  # shadow: rows 5-7 measured, rows 8-9 never measured at the clip
    img[8:], measured[8:] = 0.1, False
    before = img.copy()
    fill_unmeasured(img, i0, side, measured)
    np.testing.assert_allclose(img[3:5], 3.0, rtol=1e-5)
    np.testing.assert_allclose(img[8:], 0.01, rtol=1e-4)
    np.testing.assert_array_equal(img[measured], before[measured])
    small = before.copy()
    few = measured & (side == 1)
    few[1:3] = False  # 10 measured highlight pixels: fewer than MIN_SAMPLE
    assert np.count_nonzero(few) < MIN_SAMPLE
    fill_unmeasured(small, i0, side, few | (side <= 0))
    np.testing.assert_array_equal(small[:5], before[:5])


@pytest.mark.parametrize("clip_prior", [False, True])
def test_a_highlight_clipped_since_the_start_takes_the_level_events_carried_its_neighbours_to(clip_prior):
    """A 10 x 10 static scene whose right half is at 2 x from the start (clipped in every frame, never measured)
    and whose left half rises from 0.4 x (well exposed in frame 0) to 2 x by 8 noise-free ON events of 0.2 before
    frame 1 (clipped from then on). The events carry the left half to its level beyond the clip; the right half
    has no events and no measurement, only the bound x >= 1. With the clip prior it takes the left half's level
    (the truth, 2 x, within the events' quantisation), without it it stays at the clip level."""
    h, w = 10, 10
    n_ev = 8
    frames = np.full((4, h, w), 255, np.uint8)
    frames[0, :, :5] = round(0.4 * 255)
    ts = np.array([0, 50_000, 100_000, 150_000])
    te = ts + 5_000
    ys, xs = np.mgrid[0:h, 0:5]
    t = np.concatenate([np.full(ys.size, 10_000 + 1_000 * k) for k in range(n_ev)])
    ev = sim.make_events(t, np.tile(xs.ravel(), n_ev), np.tile(ys.ravel(), n_ev), np.ones(t.size, int))
    params = akf.AKFParams(clip_prior=clip_prior, smooth_range=0.0,  # no smoothing across the halves
                           flat_field=False)
    img = akf.reconstruct(ev, frames, ts, te, LINEAR, [125_000, 175_000], params=params, max_intensity=None)
    left = 0.4 * np.exp(0.2 * n_ev)  # 1.98 x
    np.testing.assert_allclose(img[:, :, :5], left, rtol=0.02)
    right = img[:, :, 5:]
    if clip_prior:
        np.testing.assert_allclose(right, left, rtol=0.02)
    else:
        np.testing.assert_allclose(right, 1.0, rtol=0.02)


def test_a_hot_pixel_in_a_clipped_region_leaves_every_output_finite():
    """Every frame clipped high and a hot pixel firing 600 ON events at a nominal contrast of 1: with the nominal
    threshold its estimate runs out of float32 range (no clipped frame pulls it back; published as the largest
    finite value), and with a bound the output stays finite and within it, the smoothing not spreading the
    overflow to its neighbours (OpenCV's bilateral filter turned an infinity into NaN, or crashed). At the
    defaults the flat field reads the hot pixel's threshold from its count against its neighbours': finite,
    unbounded."""
    frames = np.full((4, 12, 12), 255, np.uint8)
    ts = np.array([0, 50_000, 100_000, 150_000])
    ev = sim.make_events(np.arange(600) * 100 + 10_000, [6] * 600, [6] * 600, [1] * 600)
    nominal = akf.AKFParams(flat_field=False)
    free = akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, [175_000], contrast=1.0,
                           params=dataclasses.replace(nominal, smooth_range=0.0))
    assert free[0, 6, 6] == np.float32(LARGEST)  # the estimate did overflow: published as the largest finite value
    assert np.isfinite(akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, [175_000], contrast=1.0)).all()
    img = akf.reconstruct(ev, frames, ts, ts + 5_000, LINEAR, [90_000, 175_000], contrast=1.0, params=nominal,
                          max_intensity=1.0)
    assert np.isfinite(img).all() and img.max() <= 1.0
    np.testing.assert_allclose(np.delete(img[1].ravel(), 6 * 12 + 6), 1.0, rtol=1e-5)  # the clip level, 1 x
