"""Baselines against closed forms: the events-only high-pass filter, the complementary filter's decay toward the
frame, frames only (nearest / linear) and direct integration."""

import math

import numpy as np
import pytest

import akf
import crf_models
import sim

LINEAR = crf_models.get("linear")


def test_high_pass_filter_matches_its_closed_form():
    """x(T) = sum_i sigma_i c exp(-alpha (T - t_i)) for each pixel (Scheerlinck et al. 2018 with L^F = 0)."""
    rng = np.random.default_rng(1)
    n = 400
    t = np.sort(rng.integers(0, 2_000_000, n))
    x, y, p = rng.integers(0, 3, n), rng.integers(0, 2, n), rng.choice([-1, 1], n)
    ev = sim.make_events(t, x, y, p)
    alpha, c_on, c_off = 3.0, 0.25, 0.15
    times = np.array([500_000, 1_234_567, 2_000_000])
    out = akf.high_pass_filter(ev, (2, 3), times, contrast=(c_on, c_off), alpha=alpha)
    for j, T in enumerate(times):
        for yy in range(2):
            for xx in range(3):
                sel = (x == xx) & (y == yy) & (t < T)
                steps = np.where(p[sel] > 0, c_on, -c_off)
                expected = np.sum(steps * np.exp(-alpha * (T - t[sel]) * 1e-6))
                assert out[j, yy, xx] == pytest.approx(expected, abs=2e-6)


def test_complementary_filter_without_events_decays_to_the_new_frame():
    frames = np.array([np.full((2, 2), 50), np.full((2, 2), 200)], np.uint8)
    ts, te = np.array([0, 100_000]), np.array([10_000, 110_000])
    times = np.array([5_000, 105_000, 305_000])
    hz = 2.0
    out = akf.complementary_filter(sim.empty_events(), frames, ts, te, LINEAR, times, crossover_hz=hz, i0=1e-3)
    l0, l1 = math.log(50 / 255 + 1e-3), math.log(200 / 255 + 1e-3)
    for j, t in enumerate(times):
        # the frame at tau_1 = 105 ms replaces the low-pass input (zero-order hold)
        dt = max(t - 105_000, 0) * 1e-6
        expected = l1 + (l0 - l1) * math.exp(-2 * math.pi * hz * dt)
        assert np.log(out[j] + 1e-3) == pytest.approx(np.full((2, 2), expected), abs=1e-5)


def test_adaptive_gain_lowers_the_crossover_at_saturated_pixels():
    frames = np.array([np.full((1, 3), 100), [[255, 100, 0]]], np.uint8)
    ts, te = np.array([0, 100_000]), np.array([10_000, 110_000])
    times = [105_000, 205_000]
    plain = akf.complementary_filter(sim.empty_events(), frames, ts, te, LINEAR, times, alpha=5.0)
    adaptive = akf.complementary_filter(sim.empty_events(), frames, ts, te, LINEAR, times, alpha=5.0,
                                        adaptive_gain=True, adaptive_factor=0.1)
    l_old = math.log(100 / 255 + 1e-3)
    for k, dn in ((0, 255), (2, 0)):
        l_new = math.log(dn / 255 + 1e-3)
        assert math.log(adaptive[1, 0, k] + 1e-3) == pytest.approx(l_new + (l_old - l_new) * math.exp(-0.5 * 0.1),
                                                                   abs=1e-4)
        assert math.log(plain[1, 0, k] + 1e-3) == pytest.approx(l_new + (l_old - l_new) * math.exp(-5 * 0.1),
                                                                abs=1e-4)


def test_frames_only_nearest_and_linear():
    frames = np.array([np.full((2, 2), 51), np.full((2, 2), 153)], np.uint8)
    ts, te = np.array([0, 100_000]), np.array([10_000, 110_000])  # tau = 5 ms, 105 ms
    times = [0, 30_000, 80_000, 200_000]
    near = akf.frames_only(sim.empty_events(), frames, ts, te, LINEAR, times)
    lin = akf.frames_only(sim.empty_events(), frames, ts, te, LINEAR, times, mode="linear")
    np.testing.assert_allclose(near[:, 0, 0], [0.2, 0.2, 0.6, 0.6], rtol=1e-6)
    np.testing.assert_allclose(lin[:, 0, 0], [0.2, 0.2 + 0.4 * 0.25, 0.2 + 0.4 * 0.75, 0.6], rtol=1e-6)


def test_direct_integration_adds_contrast_times_event_count():
    frames = np.full((2, 1, 2), 51, np.uint8)
    ts, te = np.array([0, 100_000]), np.array([10_000, 110_000])
    ev = sim.make_events([1_000, 20_000, 30_000, 40_000, 150_000], [1, 1, 1, 0, 0], [0] * 5, [1, 1, 1, -1, -1])
    out = akf.direct_integration(ev, frames, ts, te, LINEAR, [50_000, 200_000], contrast=0.2, i0=1e-3)
    l0 = math.log(0.2 + 1e-3)
    # the event at 1 ms precedes tau_0 = 5 ms and is not counted
    np.testing.assert_allclose(np.log(out[:, 0] + 1e-3), [[l0 - 0.2, l0 + 0.4], [l0 - 0.4, l0 + 0.4]], atol=1e-5)


def test_crf_by_name_and_never_negative():
    """Every method takes a CRF name; reconstructions are radiance (>= 0) even where events drive the log below
    log(I0)."""
    frames = np.array([np.full((2, 2), 0), np.full((2, 2), 0)], np.uint8)
    ts, te = np.array([0, 100_000]), np.array([10_000, 110_000])
    ev = sim.make_events(np.arange(1000, 21000, 1000), np.zeros(20, int), np.zeros(20, int), -np.ones(20, int))
    times = np.array([50_000, 105_000])
    for name, fn in akf.METHODS.items():
        by_name = fn(ev, frames, ts, te, "window", times)
        by_object = fn(ev, frames, ts, te, crf_models.get("window"), times)
        np.testing.assert_array_equal(by_name, by_object)
        assert by_name.min() >= 0, name
    with pytest.raises(sim.EvsimInputError, match="unknown CRF"):
        akf.complementary_filter(ev, frames, ts, te, "no-such-curve", times)


def test_cf_output_is_bounded_where_frames_clip_and_adaptive_gain_cannot_diverge():
    """A pixel clipped high in every frame with a burst of ON events (the demo's divergence: events integrated far
    above full well): the bounded CF stays within [0, max_intensity], the adaptive one too with lambda = 0 (a pure
    integrator there); unbounded (max_intensity=None) it follows exp(n c)."""
    frames = np.full((3, 1, 2), 255, np.uint8)
    ts, te = np.array([0, 100_000, 200_000]), np.array([10_000, 110_000, 210_000])
    n = 60
    ev = sim.make_events(np.linspace(20_000, 90_000, n).astype(np.int64), np.zeros(n, int), np.zeros(n, int),
                         np.ones(n, int))
    times = np.array([95_000, 205_000])
    plain = akf.complementary_filter(ev, frames, ts, te, LINEAR, times, alpha=0.1)
    assert plain.max() <= 1.0 + 1e-6 and plain[0, 0, 0] == pytest.approx(1.0, rel=1e-5)
    adaptive = akf.complementary_filter(ev, frames, ts, te, LINEAR, times, alpha=50.0, adaptive_gain=True,
                                        adaptive_factor=0.0)
    assert adaptive.max() <= 1.0 + 1e-6
    free = akf.complementary_filter(ev, frames, ts, te, LINEAR, times, alpha=0.1, max_intensity=None)
    assert free[0, 0, 0] > 1e4  # exp(60 * 0.2) ~ 1.6e5 times the frame: the straw man the bound removes
    assert free[0, 0, 1] == pytest.approx(1.0, rel=1e-5)  # the pixel without events holds its frame
