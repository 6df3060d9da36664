"""DVS emulator pixel physics against closed forms: crossing times, contrast bookkeeping, refractory, photoreceptor."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import sim
from sim import dvs_kernels

IDEAL = sim.DVSParams.preset("ideal")
DARK = IDEAL.dark_fraction * IDEAL.full_illumination


def radiance_of_log(log_i):
    """Radiance whose pixel response log(I + dark) is log_i."""
    return np.exp(log_i) - DARK


def test_linear_log_ramp_event_times_match_analytic_crossings():
    c = 0.2
    params = IDEAL.replace(pos_threshold=c, neg_threshold=c)
    emu = sim.DVSEmulator(1, 1, params, seed=1)
    c_on, c_off = (float(v) for v in emu.threshold_map[:, 0, 0])
    slope_up, slope_down = 0.2 / 763.3, -0.2 / 211.7  # log units per us
    t_peak, t_end = 20_000, 30_000
    rng = np.random.default_rng(0)
    # irregular frame times, some intervals far longer than a threshold's worth of change; the kink is sampled
    times = np.unique(np.concatenate([[0, t_peak, t_end], rng.integers(1, t_end, 40)]))
    log_i = np.where(times <= t_peak, slope_up * times, slope_up * t_peak + slope_down * (times - t_peak))
    events = emu.feed(radiance_of_log(log_i)[:, None, None], times)

    n_up = int(np.floor(slope_up * t_peak / c_on))
    t_on = np.arange(1, n_up + 1) * c_on / slope_up
    ref_peak = n_up * c_on
    peak = slope_up * t_peak
    n_down = int(np.floor((ref_peak - (peak + slope_down * (t_end - t_peak))) / c_off))
    t_off = t_peak + ((peak - ref_peak) + np.arange(1, n_down + 1) * c_off) / -slope_down
    assert n_up > 20 and n_down > 20
    expected = np.concatenate([t_on, t_off])
    assert events.size == expected.size
    np.testing.assert_array_equal(events["p"], np.r_[np.ones(n_up), -np.ones(n_down)])
    err = events["t"] - expected
    assert np.all(err >= -1e-6) and np.all(err < 1.0), err  # stamped at the first integer us at/after the crossing
    # several crossings inside single intervals got distinct, correctly spaced times
    assert np.max(np.bincount(np.searchsorted(times, events["t"]))) >= 3


def smooth_hdr_video(h, w, times, seed, amplitude=4.0):
    """A random smooth log-radiance video (sum of drifting sinusoids), about e^(2 amplitude) : 1 contrast."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    t = times[:, None, None] / 1e6
    log_i = np.zeros((len(times), h, w))
    for _ in range(4):
        ky, kx = rng.uniform(-0.5, 0.5, 2)
        f_hz, phase = rng.uniform(2, 15), rng.uniform(0, 2 * np.pi)
        log_i += np.sin(ky * yy + kx * xx + 2 * np.pi * f_hz * t + phase)
    return np.exp(amplitude / 2 * log_i - 2.0)


@pytest.mark.parametrize("mismatch", [False, True])
def test_contrast_bookkeeping_on_smooth_hdr_video(mismatch):
    """Final log change minus threshold x signed count stays inside (-C_off, C_on) at every pixel."""
    h, w = 12, 16
    rng = np.random.default_rng(3)
    times = np.cumsum(rng.integers(200, 3000, 300)).astype(np.int64)
    frames = smooth_hdr_video(h, w, times, seed=4)
    assert frames.max() / frames.min() > 1e3
    params = IDEAL.replace(pos_threshold=0.15, neg_threshold=0.25)
    if mismatch:
        params = params.replace(threshold_sigma=0.04, cutoff_hz=200.0)  # filtered log intensity is what counts
    emu = sim.DVSEmulator(h, w, params, seed=5)
    emu.feed(frames[0], times[0])
    l_start = emu.log_intensity
    events = emu.feed(frames[1:], times[1:])
    change = emu.log_intensity - l_start
    if not mismatch:
        np.testing.assert_allclose(change, np.log(frames[-1] + DARK) - np.log(frames[0] + DARK), atol=1e-12)
    c_on, c_off = emu.threshold_map.astype(np.float64)
    n_on = np.zeros((h, w))
    n_off = np.zeros((h, w))
    np.add.at(n_on, (events["y"][events["p"] > 0], events["x"][events["p"] > 0]), 1)
    np.add.at(n_off, (events["y"][events["p"] < 0], events["x"][events["p"] < 0]), 1)
    residual = change - (c_on * n_on - c_off * n_off)
    assert events.size > 20 * h * w
    assert np.all(residual < c_on) and np.all(residual > -c_off)


def ramp_with_refractory(refractory_us, spacing_us=1000.5, t_end=40_000, frame_us=77):
    """Events of one pixel whose log intensity crosses a threshold every spacing_us (ideal pixel otherwise)."""
    params = IDEAL.replace(pos_threshold=0.2, refractory_us=refractory_us)
    emu = sim.DVSEmulator(1, 1, params, seed=0)
    c_on = float(emu.threshold_map[0, 0, 0])
    slope = c_on / spacing_us
    times = np.arange(0, t_end + 1, frame_us, dtype=np.int64)
    events = emu.feed(radiance_of_log(slope * times)[:, None, None], times)
    return events, times[-1]


@pytest.mark.parametrize("refractory_us", [300, 2500])
def test_refractory_fast_ramp_matches_analytic_events(refractory_us):
    events, t_last = ramp_with_refractory(refractory_us)
    # first crossing at 1000.5 us -> stamp 1001; blind until te + R, reference reset to the level then,
    # next crossing 1000.5 us later -> stamp te + R + 1001
    expected = 1001 + np.arange(100) * (refractory_us + 1001)
    expected = expected[expected <= t_last]
    np.testing.assert_array_equal(events["t"], expected)
    assert np.all(events["p"] == 1)
    assert np.all(np.diff(events["t"]) >= refractory_us)


def test_ramp_without_refractory_fires_every_threshold():
    events, t_last = ramp_with_refractory(0, spacing_us=1000.37)
    crossings = np.arange(1, 40) * 1000.37
    np.testing.assert_array_equal(events["t"], np.ceil(crossings[crossings <= t_last]))


@pytest.mark.parametrize("radiance", [0.5, 0.05])
def test_photoreceptor_step_response_time_constant(radiance):
    fc, full = 80.0, 2.0
    params = IDEAL.replace(cutoff_hz=fc, full_illumination=full)
    dark = params.dark_fraction * full
    tau_us = 1e6 / (2 * np.pi * fc * (radiance + dark) / full)
    emu = sim.DVSEmulator(1, 1, params, seed=0)
    emu.feed(np.full((1, 1), 0.01), 0)
    emu.feed(np.full((1, 1), radiance), 1)  # a 1 us ramp: a step
    t = np.arange(1, 6 * tau_us, tau_us / 20).astype(np.int64)[1:]
    lf = []
    for tk in t:
        emu.feed(np.full((1, 1), radiance), int(tk))
        lf.append(emu.log_intensity[0, 0])
    gap = np.log(radiance + dark) - np.array(lf)
    assert np.all(gap > 0)
    slope = np.polyfit(t, np.log(gap), 1)[0]
    assert -1 / slope == pytest.approx(tau_us, rel=1e-3)
    # the step reached 1 - 1/e of its size one time constant after the step
    l0 = np.log(0.01 + dark)
    assert np.interp(1 + tau_us, t, np.array(lf)) == pytest.approx(
        l0 + (1 - np.exp(-1)) * (np.log(radiance + dark) - l0), abs=2e-3)


@pytest.mark.parametrize("interval_over_tau", [0.2, 50.0])
def test_photoreceptor_exact_for_any_interval(interval_over_tau):
    """One interval of linear log input against a numerical ODE solution (no clamp for long intervals)."""
    fc, full = 300.0, 1.0
    params = IDEAL.replace(cutoff_hz=fc, full_illumination=full)
    dark = params.dark_fraction * full
    i0, i1 = 0.02, 0.3
    j = np.sqrt((i0 + dark) * (i1 + dark))  # the interval's photocurrent sets tau
    tau = 1e6 / (2 * np.pi * fc * j / full)
    emu = sim.DVSEmulator(1, 1, params, seed=0)
    emu.feed(np.full((1, 1), i0), 0)
    emu.feed(np.full((1, 1), i0), 1)  # filter settled at the start level (constant input)
    h = int(round(interval_over_tau * tau))
    emu.feed(np.full((1, 1), i1), 1 + h)
    l0, l1 = np.log(i0 + dark), np.log(i1 + dark)
    sol = solve_ivp(lambda t, y: (l0 + (l1 - l0) * t / h - y) / tau, (0, h), [l0], rtol=1e-10, atol=1e-12)
    # (J and the decay factor are float32, 1e-7 relative: a few 1e-7 of the log step l1 - l0 = 2.7)
    assert emu.log_intensity[0, 0] == pytest.approx(sol.y[0, -1], abs=1e-6)
    lag = l1 - emu.log_intensity[0, 0]
    assert lag > (0.5 if interval_over_tau < 1 else 1e-3)  # still lagging behind the input: not clamped


def test_8bit_level_pairs_return_ties_fire_as_the_esim_rule_says():
    """Every 8-bit level pair a -> b -> a: the pixel back at its starting level fires its last event at the tie.

    Ground truth is the ESIM rule in exact arithmetic: n = floor((L(b) - L(a)) / C) events one way, then n the
    other way, the last exactly when the level is back at L(a), i.e. at the third frame's time (not 1 us later).
    """
    levels = np.arange(1, 256)
    a, b = (v.ravel() for v in np.meshgrid(levels, levels, indexing="ij"))
    keep = a != b
    a, b = a[keep], b[keep]
    w = 254
    h = a.size // w
    emu = sim.DVSEmulator(h, w, IDEAL, seed=0)
    fa, fb = ((v / 255).astype(np.float32).reshape(h, w) for v in (a, b))
    times = np.array([0, 1000, 2000, 3000])
    events = emu.feed(np.stack([fa, fb, fa, fa]), times)
    c = float(emu.threshold_map[0, 0, 0])
    # the rule, in units of the log response's grid (where the emulator's arithmetic is exact)
    grid = dvs_kernels.LOG_GRID
    q = np.round(np.log(levels.astype(np.float32) / 255 + DARK) / grid).astype(np.int64)
    n_rule = np.abs(q[b - 1] - q[a - 1]) // int(round(c / grid))
    pix = events["y"].astype(np.int64) * w + events["x"]
    up = (b > a).astype(np.int8) * 2 - 1
    first_way = np.bincount(pix, weights=events["p"] == up[pix], minlength=a.size)
    back = np.bincount(pix, weights=events["p"] != up[pix], minlength=a.size)
    np.testing.assert_array_equal(first_way, n_rule)
    np.testing.assert_array_equal(back, n_rule)
    assert events["t"].max() == 2000  # nothing fires after the return, nothing is stamped late
    last = np.full(a.size, -1)
    np.maximum.at(last, pix, events["t"])
    assert np.all(last[n_rule > 0] == 2000)  # the tie is stamped at the frame's own microsecond
