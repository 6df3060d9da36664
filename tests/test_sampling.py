import dataclasses

import numpy as np
import pytest

import sim
from generators.sampling import AdaptiveSampler, FixedRateSampler, make_sampler
from generators.scenes import FlickeringLight, MovingEdge

EPS = 1e-4


def _max_log_steps(samples):
    times, logs = [], []
    for t, img in samples:
        times.append(t)
        logs.append(np.log(img.astype(np.float64) + EPS))
    steps = [np.abs(b - a).max() for a, b in zip(logs[:-1], logs[1:])]
    return np.array(times), np.array(steps)


def test_adaptive_keeps_log_change_below_fraction_of_threshold():
    # An edge from 0.05 to 1.0 (log contrast 3.0) moving at 400 px/s: a pixel it crosses changes by up to
    # 3.0 per pixel of motion, i.e. 3.0 * 400 = 1200 log units per second at the worst pixel.
    scene = MovingEdge(4, 64, 100_000, speed_px_per_s=400.0, x0=10.0, low=0.05, high=1.0)
    s = AdaptiveSampler(scene, threshold=0.2, fraction=0.5, min_step_us=5, max_step_us=20_000, log_eps=EPS)
    times, steps = _max_log_steps(s)
    assert times[0] == 0 and times[-1] == 100_000 and np.all(np.diff(times) > 0)
    assert times.dtype == np.int64
    assert steps.max() <= 0.1 + 1e-6
    assert s.n_samples == times.size and s.n_at_min_step == 0
    # the bound is not met by wild oversampling: the rate of change dictates about 1200 / 0.1 = 12000 samples/s
    assert s.n_samples < 3 * 12_000 * 0.1
    assert s.n_evaluations >= s.n_samples


def test_adaptive_uses_fewer_samples_than_fixed_rate_on_a_slow_scene():
    slow = MovingEdge(4, 64, 500_000, speed_px_per_s=5.0, x0=10.0, low=0.05, high=1.0)
    # the 400 px/s edge above needs 3.0 * 400 / 0.1 = 12 kHz; a fixed rate for it: 12.5 kHz (80 us steps)
    fixed = FixedRateSampler(slow, rate_hz=12_500.0)
    n_fixed = sum(1 for _ in fixed)
    adaptive = AdaptiveSampler(slow, threshold=0.2, fraction=0.5, max_step_us=20_000, log_eps=EPS)
    _, steps = _max_log_steps(adaptive)
    assert steps.max() <= 0.1 + 1e-6
    assert adaptive.n_samples < n_fixed / 10
    assert fixed.n_samples == n_fixed == 500_000 // 80 + 1


def test_step_bounds_are_respected():
    static = FlickeringLight(4, 4, 100_000, depth=0.0)  # nothing changes: steps go to the maximum
    s = AdaptiveSampler(static, threshold=0.2, max_step_us=7_000)
    times = np.array([t for t, _ in s])
    assert np.all(np.diff(times)[:-1] == 7_000) and times[-1] == 100_000
    # a step edge too fast for min_step: steps stop at min_step and say so
    fast = MovingEdge(2, 32, 1_000, speed_px_per_s=20_000.0, x0=2.0, low=0.01, high=1.0)
    s = AdaptiveSampler(fast, threshold=0.2, fraction=0.5, min_step_us=50, max_step_us=1_000)
    times = np.array([t for t, _ in s])
    assert np.diff(times)[:-1].min() >= 50 and times[-1] == 1_000
    assert s.n_at_min_step > 0


def test_fixed_rate_grid_and_flicker():
    scene = FlickeringLight(4, 4, 10_000, frequency_hz=100.0)
    s = FixedRateSampler(scene, rate_hz=3000.0)
    times = s.times()
    assert times[0] == 0 and times[-1] == 10_000 and np.all(np.diff(times)[:-1] == 333)
    for t, img in s:
        assert img[2, 2] == pytest.approx(scene.background + scene._coverage[2, 2] * scene.lamp_intensity(t), rel=1e-6)


def test_bad_sampler_arguments():
    scene = MovingEdge(2, 8, 1000)
    with pytest.raises(sim.InvalidParameterError, match="fraction"):
        AdaptiveSampler(scene, threshold=0.2, fraction=1.5)
    with pytest.raises(sim.InvalidParameterError, match="max_step_us"):
        AdaptiveSampler(scene, threshold=0.2, min_step_us=100, max_step_us=10)
    with pytest.raises(sim.InvalidParameterError, match="mode"):
        make_sampler(scene, "random")
    with pytest.raises(sim.InvalidParameterError, match="duration_us"):
        FixedRateSampler(scene, rate_hz=10, t_end_us=2000)


def test_breakpoints_are_sampled_exactly():
    scene = MovingEdge(2, 16, 50_000, speed_px_per_s=50.0)
    marks = [1234, 20_001, 49_999, 60_000]  # the last one lies outside the range and is ignored
    adaptive = np.array([t for t, _ in AdaptiveSampler(scene, threshold=0.2, max_step_us=5000, breakpoints_us=marks)])
    fixed = FixedRateSampler(scene, rate_hz=1000.0, breakpoints_us=marks).times()
    for times in (adaptive, fixed):
        assert set(marks[:3]) <= set(times.tolist()) and 60_000 not in times
        assert np.all(np.diff(times) > 0) and times[-1] == 50_000
    assert np.diff(adaptive).max() <= 5000


def _chord_time_error(delta: float) -> float:
    """Largest time error, as a fraction of the step, of linear interpolation of L = log(a + b t) over a step in
    which L changes by delta: max over levels l in [0, delta] of l / delta - (e^l - 1) / (e^delta - 1)."""
    lev = np.linspace(0.0, delta, 10_001)
    return float(np.max(lev / delta - np.expm1(lev) / np.expm1(delta)))


def test_ideal_dvs_event_times_match_analytic_crossings_within_the_sampling_bound():
    # Edge 0.05 -> 1.0 at 250 px/s: a pixel's radiance rises linearly over 4 ms, so L = log(I + eps) is log-linear
    # there and its crossings of L(0) + n C have closed-form times. Breakpoints every 10 ms stand for frame times.
    C, fraction, speed, x0, low, high = 0.2, 0.5, 250.0, 2.3, 0.05, 1.0
    scene = MovingEdge(2, 24, 80_000, speed_px_per_s=speed, x0=x0, low=low, high=high)
    params = dataclasses.replace(sim.DVSParams.preset("ideal"), full_illumination=1.0, pos_threshold=C,
                                 neg_threshold=C)
    eps = params.dark_fraction * params.full_illumination
    sampler = AdaptiveSampler(scene, threshold=C, fraction=fraction, min_step_us=5, max_step_us=5000, log_eps=eps,
                              breakpoints_us=np.arange(0, 80_001, 10_000))
    samples = list(sampler)
    times = np.array([t for t, _ in samples])
    dvs = sim.DVSEmulator(2, 24, params, seed=0)
    ev = dvs.feed(np.stack([img for _, img in samples]), times)
    assert np.isin(np.arange(10_000, 80_000, 10_000), times).all() and sampler.n_at_min_step == 0
    assert np.all(ev["p"] == 1) and np.all(ev["y"] < 2)

    c = float(np.float32(C))  # thresholds are float32
    l0, l1 = np.log(np.float32(low) + np.float32(eps)), np.log(np.float32(high) + np.float32(eps))
    n = int(np.floor((l1 - l0) / c + 1e-6))  # crossings per pixel the edge fully passes
    level_radiance = np.exp(l0 + c * np.arange(1, n + 1)) - eps
    coverage = (level_radiance - low) / (high - low)
    # Linear interpolation between samples whose max log change is <= fraction * C puts each event inside the step
    # holding its true crossing, late by at most g(fraction * C) of the step (L is concave in t there), + 1 us (ceil).
    g = _chord_time_error(fraction * C)
    assert g < 0.013  # about fraction * C / 8
    checked = 0
    for x in range(24):
        passed = scene.edge_x(80_000) - (x + 0.5)  # the ramp of pixel x ends when edge_x = x + 0.5
        mine = np.sort(ev["t"][(ev["x"] == x) & (ev["y"] == 0)])
        if x + 0.5 <= x0:  # bright from the start
            assert mine.size == 0
        if x - 0.5 < x0 or passed < 0:  # partly lit at t=0, or not fully crossed by the end
            assert mine.size <= n
            continue
        assert mine.size == n, f"pixel {x}: {mine.size} events, {n} analytic crossings"
        t_true = (coverage + x - 0.5 - x0) / speed * 1e6
        k = np.searchsorted(times, t_true)  # the step (times[k-1], times[k]] holds the crossing
        step = times[k] - times[k - 1]
        assert np.all(mine >= np.floor(t_true) - 1)  # never early (float32 rounding: 1 us)
        inside = times[k - 1] >= (x - 0.5 - x0) / speed * 1e6  # steps within the log-linear ramp
        assert np.all(mine - t_true <= np.where(inside, g * step, step) + 1.0), f"pixel {x}"
        checked += inside.sum()
    assert checked > 100


def test_quantile_bounds_that_quantile_of_the_change_not_the_worst_pixel():
    # The 400 px/s edge covers one or two of 64 columns: with quantile 0.9 the still pixels set the step, which
    # grows to max_step_us, while the bound holds for the 90th percentile of the per-pixel change at every step.
    scene = MovingEdge(4, 64, 100_000, speed_px_per_s=400.0, x0=10.0, low=0.05, high=1.0)
    worst = AdaptiveSampler(scene, threshold=0.2, fraction=0.5, min_step_us=5, max_step_us=2_000, log_eps=EPS)
    q90 = AdaptiveSampler(scene, threshold=0.2, fraction=0.5, min_step_us=5, max_step_us=2_000, log_eps=EPS,
                          quantile=0.9)
    _, worst_steps = _max_log_steps(worst)
    logs = [np.log(img.astype(np.float64) + EPS) for _, img in q90]
    q_steps = [np.quantile(np.abs(b - a), 0.9) for a, b in zip(logs[:-1], logs[1:])]
    assert max(q_steps) <= 0.1 + 1e-6 and worst_steps.max() <= 0.1 + 1e-6
    assert q90.n_samples == 100_000 // 2_000 + 1 < worst.n_samples / 10
    with pytest.raises(sim.InvalidParameterError):
        AdaptiveSampler(scene, threshold=0.2, quantile=0.3)
