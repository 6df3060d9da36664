"""The teaching lab's computations (evsim_app.lab): what each panel shows is what evsim's models give, and it moves
the way the physics says when a knob turns."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import sim
from evsim_app.cli import main
from evsim_app.lab import pixel_model, scene_model
from evsim_app.lab.pixel_model import PixelSettings, simulate_pixel
from evsim_app.lab.scene_model import SceneSettings, simulate_scene


def test_pixel_events_are_the_dvs_models_and_fall_as_the_threshold_rises():
    counts = []
    for c in (0.1, 0.2, 0.4):
        s = PixelSettings(pos_threshold=c, neg_threshold=c, threshold_sigma=0.03, shot_noise_hz=2.0)
        r = simulate_pixel(s)
        direct = sim.emulate(pixel_model.pixel_radiance(s), pixel_model.sample_times(), s.dvs_params(), s.seed)
        np.testing.assert_array_equal(r.events, direct)
        counts.append(r.n_events)
    assert counts[0] > counts[1] > counts[2]
    # an ideal pixel fires once per threshold C of the log's total variation TV (4 periods of a 0.8-log sinusoid:
    # 12.8 log units), less under two crossings per monotone stretch (9: the reference's quantisation at each end)
    r = simulate_pixel(PixelSettings(threshold_sigma=0.0, shot_noise_hz=0.0, leak_hz=0.0, cutoff_hz=0.0,
                                     refractory_us=0))
    crossings = np.sum(np.abs(np.diff(r.log_input))) / 0.2
    assert crossings - 2 * 9 <= r.n_events <= crossings


def test_pixel_noise_events_follow_the_shot_noise_rate():
    quiet = simulate_pixel(PixelSettings(shot_noise_hz=0.0, leak_hz=0.0))
    noisy = simulate_pixel(PixelSettings(shot_noise_hz=20.0, leak_hz=0.0))
    assert quiet.n_noise_events == 0
    assert 8 <= noisy.counts["shot"] <= 35  # Poisson, 20 expected in 1 s (minus the refractory's share)


def test_pixel_frames_clip_more_with_a_longer_exposure_and_the_akf_tracks_the_light():
    short = simulate_pixel(PixelSettings(exposure_us=1000))
    long = simulate_pixel(PixelSettings(exposure_us=30_000))
    assert long.frame_clipped.sum() > short.frame_clipped.sum()
    truth = np.interp(short.akf_t_us, short.t_us, short.log_input)
    assert np.median(np.abs(short.akf_log - truth)) < 0.2  # log units: within a threshold of the truth


def test_pixel_photoreceptor_lags_in_dim_light():
    bright = simulate_pixel(PixelSettings(light=1.0, shot_noise_hz=0.0, leak_hz=0.0))
    dim = simulate_pixel(PixelSettings(light=0.01, shot_noise_hz=0.0, leak_hz=0.0))
    lag = [np.mean(np.abs(np.interp(r.trace_t_us, r.t_us, r.log_input) - r.photoreceptor)) for r in (bright, dim)]
    assert lag[1] > 2 * lag[0]


def test_scene_events_fall_with_the_threshold_and_noise_is_labelled():
    low, high = simulate_scene(SceneSettings(threshold=0.2)), simulate_scene(SceneSettings(threshold=0.4))
    assert low.n_events > high.n_events > 0
    assert low.n_noise == 0
    noisy = simulate_scene(SceneSettings(noise=("shot noise",)))
    # 2 Hz per pixel over 0.1 s on 346x260 pixels: about 18 k shot events (more where it is dark)
    assert 10_000 < noisy.n_noise < 60_000
    assert low.frame.shape == (scene_model.HEIGHT, scene_model.WIDTH)
    assert low.rate_hz.sum() * scene_model.RATE_BIN_US * 1e-6 == pytest.approx(low.n_events)


def test_scene_rejects_an_unknown_noise_type():
    with pytest.raises(sim.EvsimInputError, match="unknown noise types"):
        simulate_scene(SceneSettings(noise=("dust",)))


def test_reconstruction_is_best_with_the_right_contrast():
    from evsim_app.lab import reconstruction_model as model

    n = model.reference_times().size
    picks = range(n // 4, n, n // 4)
    rmse = {s: np.mean([model.snapshot(i, s).rmse["akf"] for i in picks]) for s in (0.5, 1.0, 2.0)}
    assert rmse[1.0] < rmse[0.5] and rmse[1.0] < rmse[2.0]
    snap = model.snapshot(n // 2)
    assert snap.rmse["akf"] < snap.rmse["frames"]


def test_pixel_panel_shows_the_models_count():
    pytest.importorskip("panel", reason="the lab extra (panel) is not installed")
    from evsim_app.lab.pixel_panel import PixelPanel

    panel = PixelPanel()
    panel.w["pos_threshold"].value = 0.5
    panel.update()
    n = simulate_pixel(PixelSettings(pos_threshold=0.5)).n_events
    assert f"<b id='pixel-events'>{n}</b>" in panel.counts.object


def test_lab_without_panel_says_how_to_install_it(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "panel", None)  # import panel raises ImportError
    assert main(["lab", "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert err.strip().startswith("evsim: error:") and 'pip install "evsim[lab]"' in err
    assert "Traceback" not in err


def test_lab_rejects_a_bad_port(capsys):
    pytest.importorskip("panel", reason="the lab extra (panel) is not installed")
    assert main(["lab", "--no-browser", "--port", "70000"]) == 2
    assert "--port must be a TCP port" in capsys.readouterr().err


@pytest.mark.slow
def test_real_data_calibrated_sensor_scores_closer_than_the_guess():
    from evsim_app.lab import real_model

    if real_model.shared_recording() is None:
        pytest.skip("../shared/data is absent: no real recording")
    fitted = real_model.compare_sensor("davis346_road")
    guess = real_model.compare_sensor("davis346")
    assert abs(fitted.scores["count_ratio"] - 1) < abs(guess.scores["count_ratio"] - 1)
    on, off = fitted.counts(fitted.real, 1.0)
    assert on.sum() + off.sum() > 0
