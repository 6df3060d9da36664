"""Flickering light (generators.scenes.FlickerLighting): the events a static scene fires under it, the frames that
integrate it, and the lighting table and flag that ask for it."""

import math

import numpy as np
import pytest

import crf_models
import sim
from evsim_app.cli import main
from generators.config import build_scene
from generators.scenes import Checkerboard, FlickerLighting

H, W, DURATION_US = 20, 24, 300_000
C = 0.2


def _static(**kw):
    return Checkerboard(H, W, DURATION_US, velocity_px_per_s=(0.0, 0.0), low=0.2, high=1.0, **kw)


def test_a_static_scene_under_flicker_fires_bursts_at_its_frequency_with_the_backlash_count():
    """Every pixel's log radiance swings by A = log((1 + d) / (1 - d)) peak to peak; a pixel whose reference moves
    by C per event (an ideal DVS) fires (A - C) / C events per half cycle in the steady state, rounded to a whole
    number, ON on the rise and OFF on the fall; without the lamp the same scene fires nothing."""
    from generators.sampling import AdaptiveSampler

    params = sim.DVSParams.preset("ideal").replace(pos_threshold=C, neg_threshold=C)
    depth, f = 0.3, 100.0
    for lit, scene in ((False, _static()), (True, FlickerLighting(_static(), flicker_hz=f, depth=depth))):
        samples = AdaptiveSampler(scene, threshold=C, fraction=0.5, quantile=1.0)
        events = sim.emulate(((img, t) for t, img in samples), params=params, seed=0)
        if not lit:
            assert events.size == 0
            continue
        cycles = DURATION_US * 1e-6 * f
        per_cycle = events.size / (H * W) / cycles
        a = math.log((1 + depth) / (1 - depth))
        half = (a - C) / C
        assert 2 * math.floor(half) - 0.2 <= per_cycle <= 2 * math.ceil(half) + 0.2, (per_cycle, half)
        on = np.count_nonzero(events["p"] > 0)
        assert abs(on - events.size / 2) <= 0.05 * events.size
        rate = np.bincount(events["t"] // 1000)
        spectrum = np.abs(np.fft.rfft(rate - rate.mean()))
        assert np.fft.rfftfreq(rate.size, 1e-3)[np.argmax(spectrum)] == pytest.approx(f, rel=0.02)


def test_a_light_that_rises_fast_fires_its_on_events_in_the_rise_and_its_off_events_in_the_fall():
    """rise_fraction 0.2: the light rises over the last fifth of each period and falls over the rest, so an ideal
    pixel fires its ON events there and its OFF events in the other four fifths; the mean light is unchanged."""
    from generators.sampling import AdaptiveSampler

    rise, f, depth = 0.2, 100.0, 0.3
    scene = FlickerLighting(_static(), flicker_hz=f, depth=depth, rise_fraction=rise)
    ts = np.arange(0, 10_000, 10)
    assert np.mean([scene.gain(t) for t in ts]) == pytest.approx(1.0, abs=1e-3)
    assert max(scene.gain(t) for t in ts) == pytest.approx(1 + depth) and scene.max_frequency_hz() == 250.0
    params = sim.DVSParams.preset("ideal").replace(pos_threshold=C, neg_threshold=C)
    samples = AdaptiveSampler(scene, threshold=C, fraction=0.5, quantile=1.0)
    events = sim.emulate(((img, t) for t, img in samples), params=params, seed=0)
    cycle = (events["t"] * 1e-6 * f) % 1.0  # 0 at the peak
    on = events["p"] > 0
    assert on.sum() > 0.4 * events.size
    assert np.all((cycle[on] >= 1 - rise - 1e-3) | (cycle[on] <= 1e-3)) and np.all(cycle[~on] <= 1 - rise + 1e-3)


@pytest.mark.parametrize("t_start, exposure", [(0, 10_000), (1_234, 20_000), (0, 2_500), (3_100, 4_000)])
def test_frames_integrate_the_flicker_over_their_exposure(t_start, exposure):
    """A frame's irradiance is the scene's times the lamp's mean gain over the exposure window: 1 over whole
    periods, 1 + d (sin(w t1 + p) - sin(w t0 + p)) / (w T) otherwise."""
    depth, f, phase = 0.4, 100.0, 0.7
    base = _static()
    scene = FlickerLighting(base, flicker_hz=f, depth=depth, phase_rad=phase)
    mid = t_start + exposure // 2
    cam = sim.LDRCamera(H, W, sim.CameraParams(frame_times_us=(mid,), exposure_us=exposure), crf_models.get("linear"))
    frame = next(iter(cam.capture(scene)))
    w, t0, t1 = 2 * math.pi * f, frame.t_start_us * 1e-6, frame.t_end_us * 1e-6
    gain = 1 + depth * (math.sin(w * t1 + phase) - math.sin(w * t0 + phase)) / (w * (t1 - t0))
    np.testing.assert_allclose(frame.irradiance, base.radiance(0) * gain, rtol=0.01)
    assert frame.n_subframes >= math.ceil(exposure * 1e-6 * f * sim.camera.SUBFRAMES_PER_PERIOD)


def test_the_lighting_table_and_flag_are_checked_and_recorded(tmp_path, capsys):
    scene = build_scene({"type": "checkerboard", "lighting": {"flicker_hz": 120, "depth": 0.1}}, H, W, DURATION_US)
    assert isinstance(scene, FlickerLighting) and scene.describe()["lighting"] == {
        "flicker_hz": 120.0, "depth": 0.1, "phase_rad": 0.0, "rise_fraction": 0.5}
    with pytest.raises(sim.InvalidParameterError, match=r"scene\.lighting\.dept: unknown key 'dept' \(did you mean "
                                                        r"'depth'\?\)"):
        build_scene({"type": "checkerboard", "lighting": {"dept": 0.1}}, H, W, DURATION_US)
    with pytest.raises(sim.InvalidParameterError, match=r"lighting: depth must be in \[0, 1\), got 1.5"):
        build_scene({"type": "checkerboard", "lighting": {"depth": 1.5}}, H, W, DURATION_US)
    small = ["--scene", "checkerboard", "--duration-s", "0.05", "--height", "8", "--width", "10", "--no-progress"]
    assert main(["generate", "ahdr", *small, "--lighting", "depth=1.2", "--out", str(tmp_path / "x")]) == 2
    assert "evsim: error: --lighting: depth must be in [0, 1), got 1.2" in capsys.readouterr().err
    assert main(["generate", "ahdr", *small, "--lighting", "flicker_hz=100,depth=0.25", "--out",
                 str(tmp_path / "lit")]) == 0
    from generators import load

    meta = load(tmp_path / "lit" / "checkerboard.h5").metadata
    assert meta["scene"]["lighting"] == {"flicker_hz": 100.0, "depth": 0.25, "phase_rad": 0.0, "rise_fraction": 0.5}
    assert main(["info", str(tmp_path / "lit" / "checkerboard.h5")]) == 0
    assert "  lighting    flicker 100 Hz, depth 0.25, phase 0 rad, rising over 0.5 of the period" in \
        capsys.readouterr().out


def test_the_realism_score_finds_the_flicker_of_the_event_rate():
    """Under a cosine lamp, pixels with threshold mismatch fire ON bursts on the rise and OFF bursts on the fall,
    half a period apart: the event rate flickers at twice the lamp's frequency, the ON events alone at its
    frequency; shot noise alone has no flicker."""
    from evsim_eval.realism import compare, measure
    from generators.sampling import AdaptiveSampler

    params = sim.DVSParams.preset("ideal").replace(pos_threshold=C, neg_threshold=C, threshold_sigma=0.03)

    def events(scene, p=params):
        samples = AdaptiveSampler(scene, threshold=C, fraction=0.5, quantile=1.0)
        return sim.emulate(((img, t) for t, img in samples), params=p, seed=0)

    lit = events(FlickerLighting(_static(), flicker_hz=100.0, depth=0.3))
    both, on = (measure(e, [0, DURATION_US], height=H, width=W) for e in (lit, lit[lit["p"] > 0]))
    noise = measure(events(_static(), params.replace(shot_noise_hz=50.0)), [0, DURATION_US], height=H, width=W)
    assert both.flicker_hz == pytest.approx(200.0, rel=0.02) and both.flicker_share > 0.5
    assert on.flicker_hz == pytest.approx(100.0, rel=0.02) and on.flicker_share > 0.5
    assert math.isnan(noise.flicker_hz) and noise.flicker_share < 0.1  # white: about 3 bins of 150
    assert compare(on, on).scores["flicker_share_ratio"] == 1.0
    assert compare(on, both).scores["flicker_share_ratio"] == 0.0  # its flicker is elsewhere
    assert math.isnan(compare(noise, on).scores["flicker_share_ratio"])  # nothing to match
    from evsim_eval.calibrate.fit import flicker_warning  # calibrate says what the frames cannot give it

    note = flicker_warning(both)
    assert "the real events flicker at 200 Hz" in str(note) and "'flicker_hz': 200" in str(note)
    assert "convert with --lighting flicker_hz=200," in note.cli_message and isinstance(note, sim.EvsimNote)
    assert flicker_warning(noise) is None
