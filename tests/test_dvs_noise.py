"""DVS noise on static scenes: measured shot, leak and hot-pixel rates against the configured ones."""

import numpy as np
import pytest

import sim

IDEAL = sim.DVSParams.preset("ideal")
H, W = 40, 50
N = H * W
FRAME_US, N_FRAMES = 10_000, 201
DURATION_S = (N_FRAMES - 1) * FRAME_US / 1e6


def run_static(params, radiance=1.0, seed=0):
    emu = sim.DVSEmulator(H, W, params, seed=seed, return_labels=True)
    times = np.arange(N_FRAMES, dtype=np.int64) * FRAME_US
    frames = np.full((N_FRAMES, H, W), radiance, dtype=np.float32)
    events, labels = emu.feed(frames, times)
    return emu, events, labels


def assert_poisson_count(count, expected):
    """count within 5 standard deviations of a Poisson mean."""
    assert abs(count - expected) < 5 * np.sqrt(expected), (count, expected)


@pytest.mark.parametrize("radiance", [1.0, 0.0, 2e-4])
def test_shot_noise_rate_and_its_dark_dependence(radiance):
    params = IDEAL.replace(shot_noise_hz=15.0, dark_shot_noise_hz=45.0)
    _, events, labels = run_static(params, radiance)
    dark = params.dark_fraction * params.full_illumination
    rate = 15.0 + 45.0 * dark / (radiance + dark)
    assert_poisson_count(events.size, rate * N * DURATION_S)
    assert np.all(labels == sim.EVENT_LABELS.index("shot"))
    n_on = np.count_nonzero(events["p"] > 0)
    assert abs(n_on - events.size / 2) < 5 * np.sqrt(events.size / 4)
    # continuous timestamps: not bunched at frame times
    assert np.count_nonzero(events["t"] % FRAME_US == 0) < 0.01 * events.size
    # a Poisson process has exponential inter-arrival times: their coefficient of variation is 1
    ev = events[np.lexsort((events["t"], events["x"], events["y"]))]
    same = (np.diff(ev["y"].astype(int)) == 0) & (np.diff(ev["x"].astype(int)) == 0)
    gaps = np.diff(ev["t"])[same].astype(float)
    assert np.std(gaps) / np.mean(gaps) == pytest.approx(1.0, abs=0.05)


def test_shot_noise_respects_refractory_dead_time():
    rate, refractory = 60.0, 3000
    params = IDEAL.replace(shot_noise_hz=rate, refractory_us=refractory)
    _, events, _ = run_static(params)
    measured_expected = rate / (1 + rate * refractory * 1e-6)  # non-paralysable dead time: lost arrivals
    assert_poisson_count(events.size, measured_expected * N * DURATION_S)
    assert abs(events.size - rate * N * DURATION_S) > 10 * np.sqrt(rate * N * DURATION_S)


def test_leak_events_follow_per_pixel_leak_rates():
    params = IDEAL.replace(leak_hz=4.0, leak_spread=0.5)
    emu, events, labels = run_static(params, radiance=0.3)
    rates = emu.leak_rate_map
    # log-normal spread with mean leak_hz
    assert np.std(np.log(rates)) == pytest.approx(0.5, rel=0.05)
    sd_mean = 4.0 * np.sqrt(np.exp(0.25) - 1) / np.sqrt(N)
    assert abs(rates.mean() - 4.0) < 5 * sd_mean
    assert np.all(events["p"] == 1) and np.all(labels == sim.EVENT_LABELS.index("leak"))
    counts = np.zeros((H, W))
    np.add.at(counts, (events["y"], events["x"]), 1)
    # reference drift: a static pixel fires every 1 / rate, starting at a uniform random phase
    assert np.all(np.abs(counts - rates * DURATION_S) <= 1.0)
    assert abs(counts.sum() - rates.sum() * DURATION_S) < 5 * np.sqrt(N / 12)


def test_hot_pixels_fire_at_their_rate():
    params = IDEAL.replace(hot_pixel_fraction=0.01, hot_pixel_hz=400.0)
    emu, events, labels = run_static(params)
    mask = emu.hot_pixel_mask
    assert mask.sum() == round(0.01 * N)
    assert np.all(mask[events["y"], events["x"]])
    assert np.all(labels == sim.EVENT_LABELS.index("hot"))
    assert_poisson_count(events.size, 400.0 * mask.sum() * DURATION_S)


def test_all_noise_static_scene_labels_and_refractory():
    params = sim.DVSParams.preset("noisy", refractory_us=500)
    emu, events, labels = run_static(params, radiance=0.2, seed=3)
    assert sim.is_sorted(events)
    names = {sim.EVENT_LABELS[i] for i in np.unique(labels)}
    assert names == {"shot", "leak", "hot"}  # a static scene has no signal events
    ev = events[np.lexsort((events["t"], events["x"], events["y"]))]
    same = (np.diff(ev["y"].astype(int)) == 0) & (np.diff(ev["x"].astype(int)) == 0)
    assert np.min(np.diff(ev["t"])[same]) >= 500


@pytest.mark.parametrize("refractory_us", [0, 100_000])
def test_leak_rate_with_shot_noise_on_is_the_documented_one_and_can_be_set(refractory_us):
    """With shot noise every event resets the reference: the measured leak rate is observed_leak_hz, not leak_hz;
    with_observed_leak sets leak_hz so that a static noisy pixel shows the rate the user asks for."""
    base = IDEAL.replace(leak_hz=0.1, leak_spread=0.0, shot_noise_hz=0.1, refractory_us=refractory_us)
    hw, duration_us = (50, 80), 400_000_000
    for params, expected in ((base, base.observed_leak_hz(0.5)), (base.with_observed_leak(0.1, 0.5), 0.1)):
        emu = sim.DVSEmulator(*hw, params, seed=3, return_labels=True)
        frames = np.full((3, *hw), 0.5, dtype=np.float32)
        _, labels = emu.feed(frames, np.array([0, duration_us // 2, duration_us]))
        n_leak = np.count_nonzero(labels == sim.EVENT_LABELS.index("leak"))
        assert_poisson_count(n_leak, expected * hw[0] * hw[1] * duration_us / 1e6)
    # without noise and refractory the parameter is the static pixel's leak rate; with them it is lower
    assert IDEAL.replace(leak_hz=0.1).observed_leak_hz() == pytest.approx(0.1)
    if refractory_us == 0:
        assert base.observed_leak_hz(0.5) == pytest.approx(0.1 / (np.e - 1))  # 0.058 Hz, as measured above
    assert base.with_observed_leak(0.1, 0.5).leak_hz > 0.1


def test_dead_pixels_never_fire_and_every_other_pixel_fires_as_without_them():
    """A dead pixel drops its signal and noise events; the set is drawn from a seed of its own, so the living
    pixels' events (times, polarities, labels) are those of the same seed without dead pixels."""
    params = sim.DVSParams.preset("noisy").replace(shot_noise_hz=20.0)
    rng = np.random.default_rng(1)
    times = np.arange(41, dtype=np.int64) * FRAME_US
    frames = (0.5 + 0.4 * rng.random((41, H, W))).astype(np.float32)  # every pixel changes
    base, base_labels = sim.emulate(frames, times, params, seed=7, return_labels=True)
    assert np.unique(base["y"].astype(np.int64) * W + base["x"]).size == N  # all fire: the test can fail
    emu = sim.DVSEmulator(H, W, params.replace(dead_pixel_fraction=0.1), seed=7, return_labels=True)
    events, labels = emu.feed(frames, times)
    dead = emu.dead_pixel_mask
    assert dead.sum() == round(0.1 * N)
    assert not dead[events["y"], events["x"]].any()
    alive = ~dead[base["y"], base["x"]]
    np.testing.assert_array_equal(events, base[alive])
    np.testing.assert_array_equal(labels, base_labels[alive])
    with pytest.raises(sim.InvalidParameterError, match="dead_pixel_fraction must be in"):
        sim.DVSParams(dead_pixel_fraction=1.5)
