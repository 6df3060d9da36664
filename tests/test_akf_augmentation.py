"""Frame augmentation against closed forms: EDI deblurring of a one-pixel exposure with known radiance, and the
per-pixel contrast calibration (eq. 12) recovering known thresholds, with its guards."""

import math

import numpy as np
import pytest

from akf.augmentation import calibrate_scale, edi_deblur, event_change, interval_start
from akf.params import AKFParams
from sim.errors import InvalidParameterError
from sim.events import make_events


def test_edi_one_pixel_known_radiance():
    """Radiance steps up by exp(c) at 3 ms and down by exp(-c) at 7 ms of a 10 ms exposure (plus I0 offset)."""
    c, i0, base = 0.2, 1e-3, 0.3
    t0, t1 = 1_000, 11_000
    ev = make_events([4_000, 8_000], [0, 0], [0, 0], [1, -1])
    shifted = lambda level: (base + i0) * math.exp(level)  # I + I0 at each level
    # the blurred frame is the mean of I over the exposure: 3 ms at base, 4 ms at base*e^c, 3 ms at base
    mean_shifted = (3 * shifted(0) + 4 * shifted(c) + 3 * shifted(0)) / 10
    log_frame = np.array([math.log(mean_shifted)])
    one = np.array([c])
    start, end = edi_deblur(log_frame, ev, t0, t1, one, one, 1)
    assert start[0] == pytest.approx(math.log(base + i0), abs=1e-12)
    assert end[0] == pytest.approx(math.log(base + i0), abs=1e-12)


def test_edi_separate_on_off_thresholds_and_net_change():
    c_on, c_off, level0 = 0.25, 0.15, -1.0
    ev = make_events([2_000, 5_000, 6_000], [0, 0, 0], [0, 0, 0], [1, 1, -1])
    levels = [0.0, c_on, 2 * c_on, 2 * c_on - c_off]
    durations = [2_000, 3_000, 1_000, 4_000]  # exposure [0, 10 ms)
    mean = sum(d * math.exp(level0 + lv) for d, lv in zip(durations, levels)) / 10_000
    start, end = edi_deblur(np.array([math.log(mean)]), ev, 0, 10_000, np.array([c_on]), np.array([c_off]), 1)
    assert start[0] == pytest.approx(level0, abs=1e-12)
    assert end[0] == pytest.approx(level0 + 2 * c_on - c_off, abs=1e-12)


def test_edi_without_events_or_exposure_keeps_the_frame():
    lf = np.array([0.1, -0.4])
    ev = make_events([], [], [], [])
    s, e = edi_deblur(lf, ev, 0, 5_000, np.full(2, 0.2), np.full(2, 0.2), 2)
    np.testing.assert_allclose(s, lf, atol=1e-15)
    np.testing.assert_allclose(e, lf, atol=1e-15)
    s, e = edi_deblur(lf, ev, 7, 7, np.full(2, 0.2), np.full(2, 0.2), 2)
    np.testing.assert_array_equal(s, lf)


def test_calibration_recovers_per_pixel_thresholds():
    """Pixels with true thresholds 0.12..0.3 fire n events each for a log change n * c_true; with the nominal 0.2
    the calibrated threshold scale * 0.2 equals c_true exactly (eq. 12)."""
    rng = np.random.default_rng(5)
    h, w = 3, 4
    c_true = rng.uniform(0.12, 0.3, h * w)
    n = rng.integers(2, 6, h * w) * rng.choice([-1, 1], h * w)
    ts, xs, ys, ps = [], [], [], []
    for i in range(h * w):
        for k in range(abs(n[i])):
            ts.append(1000 + 37 * k + i)
            xs.append(i % w)
            ys.append(i // w)
            ps.append(np.sign(n[i]))
    order = np.argsort(ts, kind="stable")
    ev = make_events(np.array(ts)[order], np.array(xs)[order], np.array(ys)[order], np.array(ps)[order])
    nominal = np.full(h * w, 0.2)
    change, net = event_change(ev, nominal, nominal, w)
    np.testing.assert_array_equal(net, n)
    d_start = rng.normal(-1, 0.5, h * w)
    d_end = d_start + n * c_true
    scale = calibrate_scale(d_start, d_end, change, net, np.zeros(h * w, bool), AKFParams(calib_scale_range=(0.5, 2)))
    np.testing.assert_allclose(scale * 0.2, c_true, rtol=1e-12)
    # with the calibrated scale the forward and backward interpolations coincide: the curve starts at L^D_start
    np.testing.assert_allclose(interval_start(d_start, d_end, change, scale, np.zeros(h * w, bool)), d_start,
                               atol=1e-12)


def test_calibration_guards():
    p = AKFParams(calib_min_events=2, calib_scale_range=(0.5, 2.0))
    d_start = np.zeros(5)
    d_end = np.array([0.3, 0.3, -0.4, 0.3, 0.3])
    change = np.array([0.2, 0.4, 0.4, 0.4, 0.4])
    net = np.array([1, 2, 2, 2, 2])
    clipped = np.array([False, False, False, True, False])
    scale = calibrate_scale(d_start, d_end, change, net, clipped, p)
    # too few events, ok, opposite sign, clipped, ok
    np.testing.assert_allclose(scale, [1.0, 0.75, 1.0, 1.0, 0.75])
    big = calibrate_scale(d_start, np.full(5, 2.0), change, net, np.zeros(5, bool), p)
    np.testing.assert_allclose(big, [1.0, 1.0, 1.0, 1.0, 1.0])  # ratio 5 is outside the range
    off = calibrate_scale(d_start, d_end, change, net, clipped, AKFParams(calibrate=False))
    np.testing.assert_array_equal(off, np.ones(5))


def test_uncalibrated_curve_anchors_to_the_reliable_frame():
    d_start, d_end = np.array([0.0, 0.0]), np.array([0.5, 0.5])
    change, scale = np.array([0.2, 0.2]), np.ones(2)
    start = interval_start(d_start, d_end, change, scale, np.array([False, True]))
    np.testing.assert_allclose(start, [0.3, 0.0])  # backward from the end frame; forward where only it is clipped


def test_augmented_measurement_follows_calibrated_events_and_blends_across_exposures():
    """Pixel 1 of a 1x2 sensor, linear CRF, no deblurring: frames at 0.2, 0.2 e^0.75, 0.2 e^0.25 (logs d0, d1, d2),
    ON events (nominal contrast 0.2) at 20, 30, 40 and 55 ms (inside frame 1's exposure), OFF events at 65, 70,
    80 ms. Interval 0 spans [s_0, e_1) with change 0.8, so its calibrated scale is s0 = (d1 - d0) / 0.8 (eq. 12)
    and its curve M0 = d0 + s0 * change; interval 1 spans [s_1, e_2) with change -0.4, s1 = (d2 - d1) / -0.4 and
    M1 = d1 + s1 * change. Before frame 1 L^A = M0; across frame 1's exposure it blends M0 into M1 (eq. 13)."""
    import akf
    import crf_models
    from akf.noise import frame_measurement

    params = akf.AKFParams(deblur=False, flat_field=False)  # a 1x2 sensor: the given thresholds
    linear = crf_models.get("linear")
    y = 0.2 * np.exp(np.array([[[0.0, 0.0]], [[0.0, 0.75]], [[0.0, 0.25]]]))
    frames = np.round(y * 255).astype(np.uint8)
    ts = np.array([0, 50_000, 100_000])
    te = ts + 10_000
    ev = make_events([20_000, 30_000, 40_000, 55_000, 65_000, 70_000, 80_000], [1] * 7, [0] * 7,
                     [1, 1, 1, 1, -1, -1, -1])
    t = np.array([15_000, 25_000, 35_000, 45_000, 50_000, 55_000, 57_500, 60_000])
    aug = akf.augmented_measurement(ev, frames, ts, te, linear, t, [1], params=params)
    d0, d1, d2 = (frame_measurement(frames[k] / 255.0, linear, params).log[0, 1] for k in range(3))
    s0, s1 = (d1 - d0) / 0.8, (d2 - d1) / -0.4
    m0 = d0 + s0 * np.array([0.0, 0.2, 0.4, 0.6, 0.6, 0.6, 0.8, 0.8])
    m1 = d1 + s1 * np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.2, 0.2])
    w = np.clip((t - 50_000) / 10_000, 0, 1) * (t >= 50_000)
    np.testing.assert_allclose(aug.log[:, 0], m0 + w * (m1 - m0), rtol=0, atol=1e-12)
    assert 0.9 < s0 < 0.97 and 1.2 < s1 < 1.3  # calibrated scales (ratios to nominal), clearly not 1
    np.testing.assert_allclose(aug.intensity[:, 0], frames[:, 0, 1] / 255.0, rtol=1e-12)
    np.testing.assert_allclose(aug.deblurred[:, :, 0], [[d0, d0], [d1, d1], [d2, d2]], rtol=0, atol=1e-12)
    assert not aug.clipped.any()
    with pytest.raises(InvalidParameterError, match="pixel indices"):
        akf.augmented_measurement(ev, frames, ts, te, linear, t, [2], params=params)
