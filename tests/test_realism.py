"""The realism score (evsim_eval.realism) against ground truth: a simulation scored against itself at another seed
is perfect within the seed noise the score predicts; doubled shot noise shows as a noise-rate ratio of 2; coverage
gaps are found where events were cut out; the real DAVIS346 recording against itself, in two layouts, is perfect.

Tolerances come from Comparison.seed_noise, the deviation Poisson sampling of the measured counts gives:
- ratios: seed_noise is the relative standard deviation of the ratio, so |ratio - expected| <= 4 sd x expected
  (a false failure once in 16,000 checks);
- correlation shortfalls, RMS error, L1 distance: seed_noise is their expected value under Poisson sampling. Each
  is a sum of many independent magnitudes (bins, pixels), whose standard deviation is well below its mean (for
  L1 = sum |d_k| over n_eff comparable bins, sd / mean = sqrt((pi / 2 - 1) / n_eff), 0.25 at n_eff = 9), so twice
  the expectation is more than four standard deviations above it. DVS signal events are less random than Poisson,
  which only makes the scores better.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import sim
from evsim_eval.realism import PERFECT, compare, measure, measure_recording, score_recordings
from generators.formats import load
from generators.formats.recording import Recording

H, W = 48, 64
DURATION_US = 1_000_000
FRAME_US = 40_000  # the APS frames: 25 fps
READ_NOISE_DN = 1.0
SQUARE = (200_000, 800_000)  # the bright square crosses the sensor in this time (us)
RATIOS = ("count_ratio", "on_ratio", "off_ratio", "quiet_on_ratio", "quiet_off_ratio", "dark_on_ratio",
          "dark_off_ratio")
SHORTFALLS = ("count_corr", "count_corr_blurred", "rate_corr", "rate_rel_rmse", "interval_l1")
NOISE_RATIOS = ("quiet_on_ratio", "quiet_off_ratio", "dark_on_ratio", "dark_off_ratio")


def _scene_dn(t_us: int) -> np.ndarray:
    """(H, W) 8-bit DN: a static texture with a dark band (8 DN) on the left, and a bright square (200 DN) crossing
    rows 18-29 from left to right during SQUARE."""
    yy, xx = np.mgrid[0:H, 0:W]
    dn = 60 + 40 * np.sin(xx / 5.0) * np.cos(yy / 7.0)
    dn[:, :10] = 8.0
    x0 = (t_us - SQUARE[0]) / (SQUARE[1] - SQUARE[0]) * (W + 12) - 12
    square = (yy >= 18) & (yy < 30) & (xx >= x0) & (xx < x0 + 12)
    return np.where(square, 200.0, dn)


def _params(shot_hz: float) -> sim.DVSParams:
    # shot noise only (no leak, no hot pixels), so that the static pixels' events are shot noise
    return sim.DVSParams.preset("davis346", leak_hz=0.0, hot_pixel_fraction=0.0, shot_noise_hz=shot_hz,
                                dark_shot_noise_hz=shot_hz)


def _recording(seed: int, params: sim.DVSParams) -> Recording:
    """Events of the scene (radiance = DN / 255, sampled every 2 ms) and 25 fps 8-bit frames with read noise."""
    times = np.arange(0, DURATION_US + 1, 2000, dtype=np.int64)
    radiance = np.stack([_scene_dn(t) / 255.0 for t in times]).astype(np.float32)
    events = sim.emulate(radiance, times, params, seed=seed)
    rng = np.random.default_rng(seed)
    mid = np.arange(0, DURATION_US + 1, FRAME_US, dtype=np.int64)
    aps = np.stack([np.clip(np.round(_scene_dn(t) + rng.normal(0, READ_NOISE_DN, (H, W))), 0, 255) for t in mid])
    return Recording(events, H, W, frames=aps.astype(np.uint8), frame_t_start_us=mid, frame_t_mid_us=mid,
                     frame_t_end_us=mid)


@pytest.fixture(scope="module")
def sims():
    return {"a": _recording(1, _params(1.0)), "b": _recording(2, _params(1.0)),
            "double": _recording(2, _params(2.0))}


@pytest.fixture(scope="module")
def real_stats(sims):
    return measure_recording(sims["a"], (0.0, 1.0))


def test_pixel_classes_match_the_scene(real_stats):
    m = real_stats.masks
    yy, xx = np.mgrid[0:H, 0:W]
    crossed = (yy >= 18) & (yy < 30)
    assert not np.any(m.quiet & (yy >= 16) & (yy < 32))  # the square's rows and 2 pixels around are not quiet
    assert np.all(m.quiet[:14, 2:] | (xx[:14, 2:] >= 8) & (xx[:14, 2:] < 12))  # quiet away from the square...
    assert np.array_equal(m.dark, m.quiet & (xx < 10))  # ...dark exactly on the 8 DN band
    # motion: the square's rows change during its passage, nothing changes outside them
    moving = m.motion.reshape(-1, H, W)
    assert moving[:, crossed].any() and not moving[:, ~crossed].any()
    assert m.read_noise_dn == pytest.approx(READ_NOISE_DN, rel=0.3)


def test_simulation_against_itself_at_another_seed_is_perfect_within_seed_noise(sims, real_stats):
    c = compare(real_stats, measure_recording(sims["b"], like=real_stats))
    for k in RATIOS:
        assert abs(c.scores[k] - 1) <= 4 * c.seed_noise[k], (k, c.scores[k], c.seed_noise[k])
    for k in SHORTFALLS:
        assert abs(c.scores[k] - PERFECT[k]) <= 2 * c.seed_noise[k], (k, c.scores[k], c.seed_noise[k])
    assert abs(c.scores["passage_median_diff"]) <= 4 * c.seed_noise["passage_median_diff"]
    # the passages are the square's edges: ln(200 / 60) / 0.2 = 6 threshold crossings, fewer on the darker
    # texture's side of the edge; noise bursts on static pixels are not passages
    assert 3 <= real_stats.passage_median <= 6
    assert real_stats.passages.size > 12 * 40  # each of the 12 rows' pixels, at least once


def test_doubled_shot_noise_doubles_the_static_noise_rates(sims, real_stats):
    c = compare(real_stats, measure_recording(sims["double"], like=real_stats))
    for k in NOISE_RATIOS:  # the expected ratio is 2; seed_noise is the ratio's relative sd
        assert abs(c.scores[k] - 2) <= 4 * 2 * c.seed_noise[k], (k, c.scores[k], c.seed_noise[k])
    # the extra noise also shows in the interval histogram, beyond seed noise
    assert c.scores["interval_l1"] > 4 * c.seed_noise["interval_l1"]
    # the static pixels' rate itself: shot noise at 1 Hz per pixel, ON and OFF together
    on, off = real_stats.quiet_hz
    n = real_stats.quiet_counts[0] + real_stats.quiet_counts[1]
    assert on + off == pytest.approx(1.0, abs=4 / np.sqrt(n))


def test_noise_ratios_carry_a_poisson_interval_that_holds_the_true_ratio(sims, real_stats):
    c = compare(real_stats, measure_recording(sims["double"], like=real_stats))
    assert set(c.intervals) == set(NOISE_RATIOS)
    for k in NOISE_RATIOS:  # doubled shot noise: the true ratio is 2
        lo, hi = c.intervals[k]
        assert lo < c.scores[k] < hi and lo < 2 < hi, (k, lo, c.scores[k], hi)
    assert c.to_dict()["intervals"]["quiet_off_ratio"] == list(c.intervals["quiet_off_ratio"])


def test_coverage_gaps_are_found_and_not_scored(sims, real_stats):
    rec = sims["a"]
    t = rec.events["t"]
    cut_from, cut_to = 500_000, 620_000
    kept = rec.events[(t < cut_from) | (t >= cut_to)]
    holed = Recording(kept, H, W, frames=rec.frames, frame_t_start_us=rec.frame_t_start_us,
                      frame_t_mid_us=rec.frame_t_mid_us, frame_t_end_us=rec.frame_t_end_us)
    stats = measure_recording(holed, (0.0, 1.0))
    (g0, g1), = stats.gaps_us  # one gap, from just after the last event before the cut to the first one after it
    assert g0 == int(t[t < cut_from][-1]) + 1 and g1 == int(t[t >= cut_to][0])
    assert stats.notes and "gap" in stats.notes[0] and "0.500-0.620" in stats.notes[0]
    # scored on the covered windows only: the complete recording measured there matches exactly
    c = compare(stats, measure(rec.events, like=stats))
    assert c.scores["count_ratio"] == 1 and c.scores["interval_l1"] == 0 and c.scores["rate_rel_rmse"] == 0
    # the complete recording, whose quietest bins hold a few events, has no gap
    assert real_stats.gaps_us.size == 0


def test_a_sparse_stream_has_no_gaps():
    # a still scene with little noise: many 10 ms bins are empty by chance, none is a gap
    still = sim.emulate(np.full((101, H, W), 0.3, np.float32), np.arange(101, dtype=np.int64) * 10_000,
                        _params(0.05), seed=3)  # 3072 pixels x 0.05 Hz: 1.5 events per 10 ms bin
    stats = measure(still, (0, 1_000_000), height=H, width=W, detect_gaps=True)
    assert stats.gaps_us.size == 0 and np.mean(stats.rate_counts == 0) > 0.005


def test_gated_events_are_scored_on_the_exposures(sims):
    # an exposure-gated export: events only within 5 ms of each frame time
    rec = sims["a"]
    t = rec.events["t"]
    near = np.abs(t - np.round(t / FRAME_US) * FRAME_US) < 5_000
    gated = Recording(rec.events[near], H, W, frames=rec.frames, frame_t_start_us=rec.frame_t_start_us,
                      frame_t_mid_us=rec.frame_t_mid_us, frame_t_end_us=rec.frame_t_end_us)
    stats = measure_recording(gated, (0.0, 1.0))
    assert stats.n_events == np.count_nonzero(near)  # only empty time is cut
    # while the square crosses, the stream is busy: the scored time is the 10 ms around each frame time (a quarter
    # of every 40 ms frame interval), each window holding one frame time, the empty 30 ms between them cut out
    lo, hi = SQUARE[0] + 50_000, SQUARE[1] - 50_000
    inside = [(max(a, lo), min(b, hi)) for a, b in stats.windows_us if a < hi and b > lo]
    assert sum(b - a for a, b in inside) / (hi - lo) == pytest.approx(0.25, abs=0.03)
    frames = np.arange(0, DURATION_US + 1, FRAME_US)
    assert all(np.any((frames >= a - 5_000) & (frames < b + 5_000)) for a, b in inside)
    assert any("gap" in n for n in stats.notes)


def test_measure_refuses_mixed_arguments(real_stats, sims):
    with pytest.raises(sim.EvsimInputError, match="like"):
        measure(sims["b"].events, (0, 10), like=real_stats)
    with pytest.raises(sim.EvsimInputError, match="different time windows"):
        compare(real_stats, measure(sims["b"].events, (0, 500_000), height=H, width=W))
    with pytest.raises(sim.EvsimInputError, match="end after"):
        measure(sims["b"].events, (10, 10), height=H, width=W)


# ----- the real DAVIS346 recording -------------------------------------------------------------------------

ROAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "davis346_road"


@pytest.fixture(scope="module")
def road():
    if not (ROAD / "ijrr").is_dir():
        pytest.skip(f"real data absent: {ROAD}")
    return load(ROAD / "ijrr")


def test_real_recording_against_itself_is_perfect(road):
    c = score_recordings(road, road, (0.4, 2.32))
    assert c.scores["count_ratio"] == 1 and c.scores["count_corr"] == pytest.approx(1)
    assert c.scores["rate_rel_rmse"] == 0 and c.scores["interval_l1"] == 0
    assert c.scores["passage_median_diff"] == 0
    # the measurement: 61.9 k events in 0.4-2.32 s, a few thousandths of an event per second on quiet
    # static pixels, 3 events per pixel per car passage; complete coverage
    assert c.real.n_events == 61_896 and c.real.gaps_us.size == 0
    assert 1e-3 < c.real.quiet_hz[0] < 4e-3 and c.real.passage_median == 3


def test_real_recording_in_two_layouts_scores_perfect(road):
    pytest.importorskip("aedat", reason="the optional 'aedat' package reads AEDAT4")
    aedat = load(ROAD / "davis346_road.aedat4")  # absolute times; the IJRR export counts from t0
    c = score_recordings(aedat, road)
    assert c.scores["count_ratio"] == 1 and c.scores["rate_rel_rmse"] == 0 and c.scores["interval_l1"] == 0


def test_cli_prints_the_table_and_writes_json(tmp_path, sims, capsys):
    from evsim_app.cli import main
    from generators.formats import export

    export(sims["a"], tmp_path / "real.h5", "native")
    export(sims["double"], tmp_path / "sim.h5", "native")
    out = tmp_path / "r.json"
    assert main(["evaluate", str(tmp_path / "real.h5"), "--task", "realism", "--against", str(tmp_path / "sim.h5"),
                 "--window", "0.1", "0.9", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "events (0.1-0.9 s)" in text and "noise on quiet static pixels, ON" in text
    result = json.loads(out.read_text())
    assert abs(result["scores"]["quiet_on_ratio"] - 2) < 0.5 and result["real"]["windows_s"] == [[0.1, 0.9]]
    assert main(["evaluate", str(tmp_path / "real.h5"), "--task", "realism"]) == 2
    assert "--against" in capsys.readouterr().err


def test_plot_realism_draws_both_recordings(tmp_path, sims):
    pytest.importorskip("matplotlib")
    from evsim_app.plots.realism import plot_realism

    real, double = sims["a"], sims["double"]
    c = score_recordings(real, double, (0.0, 1.0))
    out = tmp_path / "realism.png"
    res = plot_realism(c, real, double, out, at_s=0.5, window_ms=20)
    assert out.stat().st_size > 10_000
    for rec, frame in zip((real, double), res["frames"]):  # the event frames hold the events of 0.49-0.51 s
        t = rec.events["t"]
        assert frame.sum() == np.count_nonzero((t >= 490_000) & (t < 510_000))


def test_measure_refuses_events_it_cannot_score(real_stats, sims):
    events = sims["b"].events
    with pytest.raises(sim.EvsimInputError, match="sorted"):
        measure(events[::-1], like=real_stats)
    with pytest.raises(sim.EvsimInputError, match="outside the 32x48 sensor"):
        measure(events, (0, 10_000), height=H, width=32)
    with pytest.raises(sim.EvsimInputError, match="EVENT_DTYPE"):
        measure(np.zeros(3), like=real_stats)


def test_cli_refuses_bad_realism_requests(tmp_path, sims, capsys):
    from evsim_app.cli import main
    from generators.formats import export

    export(sims["a"], tmp_path / "real.h5", "native")
    small = Recording(sims["b"].events[sims["b"].events["x"] < 32], H, 32)
    export(small, tmp_path / "small.h5", "native")
    base = ["evaluate", str(tmp_path / "real.h5"), "--task", "realism"]
    for extra, message in ((["--against", str(tmp_path / "real.h5"), "--window", "0.5", "0.2"], "START_S < END_S"),
                           (["--against", str(tmp_path / "small.h5")], "simulate at the real sensor's size"),
                           (["--against", str(tmp_path / "real.h5"), "--workers", "2"], "drop --workers"),
                           (["--against", str(tmp_path / "missing.h5")], "missing.h5")):
        assert main(base + extra) == 2, extra
        err = capsys.readouterr().err
        assert err.startswith("evsim: error:") and message in err and "Traceback" not in err, err


def test_without_frames_quiet_pixels_come_from_the_events(sims):
    """Events only: quiet pixels from the events (evsim_eval.realism.event_masks), so the quiet noise is scored;
    dark pixels and passages need frames and are not."""
    bare = Recording(sims["a"].events, H, W)  # events only, as `evsim convert` writes by default
    c = score_recordings(bare, sims["b"])
    assert c.real.masks.source == "events"
    assert all(math.isnan(c.scores[k]) for k in ("dark_on_ratio", "dark_off_ratio"))
    assert math.isnan(c.scores["passage_median_diff"])
    quiet = c.real.masks.quiet
    assert not quiet[18:30].any() and quiet[:12].mean() > 0.8  # the square's rows are not quiet, the far ones are
    for k in ("quiet_on_ratio", "quiet_off_ratio"):
        assert abs(c.scores[k] - 1) <= 4 * c.seed_noise[k]
    assert abs(c.scores["count_ratio"] - 1) <= 4 * c.seed_noise["count_ratio"]
    assert any("no frames" in n for n in c.notes)



def test_a_conversion_on_the_recordings_clock_is_scored_from_the_recordings_time_zero():
    """A conversion of a recording's frames holds no frames and starts its events at the first frame's mid-exposure
    (the scene's time zero), not at the exposure start (the recording's): scored on the recording's clock, the same
    events give a perfect rate curve (before, the windows were shifted by the first event's delay)."""
    from dataclasses import replace

    from evsim_eval.realism.stats import same_clock

    from recordings import make_recording

    real = make_recording(n_events=20000)
    late = real.events[real.events["t"] > real.frame_t_mid_us[0]]  # a conversion's events start at time zero
    real = replace(real, events=late)
    converted = Recording(events=late.copy(), height=real.height, width=real.width,
                          metadata={"time_origin_us": int(real.frame_t_mid_us[0])})
    assert same_clock(real, converted) and not same_clock(converted, real)
    scores = score_recordings(real, converted).scores
    assert scores["count_ratio"] == 1.0 and scores["rate_rel_rmse"] == pytest.approx(0.0, abs=1e-12)
