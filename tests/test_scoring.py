"""What the evaluation compares, checked against ground truth: exposure-matched scoring of a blurred held-out frame
(the truth integrated over the exposure scores about 0, the truth at mid-exposure does not), the white point a
method can reach, the pixel/time classes on a hand-made case, the truth against the frames' range and log_rmse
pooled over a class, the default headline and the figures of its JSON, and scores between frames."""

import json
from pathlib import Path

import numpy as np
import pytest

import crf_models
import evsim_eval.exposure
import sim
from evsim_app.cli import main
from evsim_eval.choices import DEFAULT_METRICS
from evsim_eval.evaluate import add_means, evaluate_dataset, evaluate_recording, request_defaults
from evsim_eval.exposure import MAX_SAMPLES, MIN_SAMPLES, exposure_average, sample_count, sample_times
from evsim_eval.metrics import mse01, score_map, ssim01
from evsim_eval.pixel_classes import CLASSES, RANGE_CLASSES
from evsim_eval.protocols import recording_case
from evsim_eval.scoring import Case, reachable_white, white_cap
from generators import load
from generators.ahdr import AHDRConfig, generate_ahdr
from generators.scenes import MovingEdge
from sim import EVENT_DTYPE

# ----- exposure-matched scoring ------------------------------------------------------------------------------------

SPEED, EXPOSURE = 200.0, 20_000  # px/s and us: a 4 px motion blur in every frame


@pytest.fixture(scope="module")
def blurred(tmp_path_factory):
    """A noise-free sequence (ideal DVS and camera, 12-bit linear frames integrated with 400 sub-frames: the exact
    blur) of an edge moving 4 px per exposure, HDR references at 100 Hz (inside and between exposures), and its
    scene."""
    scene = MovingEdge(12, 40, 400_000, speed_px_per_s=SPEED, x0=4.0, low=0.1, high=1.0)
    camera = sim.CameraParams.preset("ideal", exposure_us=EXPOSURE, bit_depth=12, n_subframes=400)
    config = AHDRConfig(dvs=sim.DVSParams.preset("ideal"), camera=camera, crf="linear", compression=None,
                        auto_exposure=False, reference_rate_hz=100.0)
    path = tmp_path_factory.mktemp("blur") / "edge.h5"
    generate_ahdr(scene, path, config, 0, progress=False)
    return load(path), scene


def _oracle(scene, to_x):
    """A 'method' that returns the true scene at any time (x units)."""
    def truth(events, frames, t_start, t_end, crf, times, **_):
        return np.stack([scene.radiance(int(t)) * to_x for t in times]).astype(np.float32)
    return truth


def test_exposure_matched_scoring_gives_the_truth_a_zero_score_where_point_scoring_does_not(blurred, monkeypatch):
    rec, scene = blurred
    to_x = rec.metadata["reference_to_crf_x"]
    monkeypatch.setitem(evsim_eval.scoring.METHODS, "truth", _oracle(scene, to_x))
    case, _ = recording_case(rec, "interleave")
    assert case.scoring == "exposure-matched" and case.windows.shape == (case.times.size, 2)
    np.testing.assert_array_equal(case.windows[:, 1] - case.windows[:, 0], EXPOSURE)
    matched = case.scores(case.run("truth"), slice(None), ("mse01", "ssim01"))
    point_case, _ = recording_case(rec, "interleave", exposure_matched=False)
    assert point_case.scoring == "point-in-time"
    point = point_case.scores(point_case.run("truth"), slice(None), ("mse01", "ssim01"))
    # the truth integrated over the exposure is the held-out frame up to 12-bit quantisation and the midpoint rule
    assert matched["mse01"] < 2e-6 and matched["ssim01"] > 0.999
    # the sharp truth at mid-exposure differs from the 4 px blurred frame at the edge
    assert point["mse01"] > 100 * matched["mse01"] and point["ssim01"] < 0.99


def test_exposure_average_is_the_mean_of_midpoint_samples_and_the_count_follows_the_events(monkeypatch):
    assert sample_times(1000, 2000, 4).tolist() == [1125, 1375, 1625, 1875]
    ev = np.zeros(0, EVENT_DTYPE)
    assert sample_count(ev, 0, 1000, (2, 2)) == MIN_SAMPLES  # no events: smooth, the minimum
    assert sample_count(ev, 500, 500, (2, 2)) == 1  # no exposure recorded: the point-in-time value
    busy = np.zeros(30, EVENT_DTYPE)  # 10 events in each of 3 pixels: 4 samples per event
    busy["t"] = np.arange(30) * 10
    busy["x"] = np.repeat([0, 1, 0], 10)
    busy["y"] = np.repeat([0, 0, 1], 10)
    assert sample_count(busy, 0, 1000, (2, 2)) == 40
    busy["x"], busy["y"] = 0, 0  # 30 events in one pixel: capped
    assert sample_count(busy, 0, 1000, (2, 2)) == MAX_SAMPLES
    # a pixel ramping linearly in time: the midpoint mean is the exact mean over the window
    images, counts = exposure_average(lambda t: np.asarray(t, np.float64)[:, None, None] * np.ones((1, 2, 2)),
                                      ev, [[0, 1000], [2000, 2600]], (2, 2))
    assert counts.tolist() == [MIN_SAMPLES, MIN_SAMPLES]
    np.testing.assert_allclose(images[:, 0, 0], [500, 2300], atol=0.5)
    # windows are reconstructed in groups that fit the memory budget: the same averages, in more calls
    windows = [[k * 1000, k * 1000 + 600] for k in range(20)]
    calls = []

    def ramp(t):
        calls.append(len(t))
        return np.asarray(t, np.float64)[:, None, None] * np.ones((1, 2, 2))
    whole, _ = exposure_average(ramp, ev, windows, (2, 2))
    monkeypatch.setattr(evsim_eval.exposure, "_CHUNK_BYTES", 1)  # budget: MAX_SAMPLES samples per call
    parts, _ = exposure_average(ramp, ev, windows, (2, 2))
    assert calls[0] == 20 * MIN_SAMPLES and calls[1:] == [MAX_SAMPLES] * 2 + [20 * MIN_SAMPLES - 2 * MAX_SAMPLES]
    np.testing.assert_array_equal(parts, whole)
    np.testing.assert_allclose(whole[:, 0, 0], [k * 1000 + 300 for k in range(20)], atol=0.5)


def test_point_scoring_flag_and_the_table_and_json_say_which(blurred, tmp_path, capsys):
    rec, _ = blurred
    path = tmp_path / "edge.h5"
    from generators.formats import export
    export(rec, path, "native")
    out = {}
    for flag in ([], ["--point-scoring"]):
        js = tmp_path / f"s{len(flag)}.json"
        assert main(["evaluate", str(path), "--protocol", "interleave", "--methods", "frames", "--metrics",
                     "mse01,ssim01", "--json", str(js), *flag]) == 0
        text = capsys.readouterr().out
        out[bool(flag)] = json.loads(js.read_text())
        assert ("scoring: point-in-time" in text) == bool(flag)
        assert ("scoring: exposure-matched" in text) == (not flag)
        assert out[bool(flag)]["scoring"]["exposure_matched"] == (not flag)
    assert out[True]["frames"]["edge"]["mse01"] != out[False]["frames"]["edge"]["mse01"]


ROAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "davis346_road"


def test_real_ijrr_export_carries_the_aedat4_exposure_windows():
    """The shared DAVIS346 recording's IJRR export lists its exposures in frame_exposures.txt (times from t0)."""
    pytest.importorskip("aedat", reason="the optional 'aedat' package reads AEDAT4")
    if not (ROAD / "ijrr" / "frame_exposures.txt").is_file():
        pytest.skip(f"real data absent: {ROAD}")
    ijrr, aedat4 = load(ROAD / "ijrr"), load(ROAD / "davis346_road.aedat4")
    t0 = int((ROAD / "ijrr" / "t0_us.txt").read_text())
    np.testing.assert_array_equal(ijrr.frame_t_end_us - ijrr.frame_t_start_us, 500)  # README: a fixed 500 us
    np.testing.assert_array_equal(ijrr.frame_t_start_us + t0, aedat4.frame_t_start_us)
    np.testing.assert_array_equal(ijrr.frame_t_end_us + t0, aedat4.frame_t_end_us)
    case, _ = recording_case(ijrr, "interleave", sensor="davis346_road")  # (no threshold estimate: not tested here)
    np.testing.assert_array_equal(case.windows[:, 1] - case.windows[:, 0], 500)


# ----- the white point ---------------------------------------------------------------------------------------------

def test_white_point_is_what_a_method_can_reach_so_scores_no_longer_tie():
    rng = np.random.default_rng(0)
    truth = rng.uniform(0.05, 0.9, (40, 40))
    truth[:, 30:] = 300.0  # a sun: the scene's 98th percentile is 300 x, 300 times the output bound
    good = np.minimum(truth, 1.0)  # right wherever the output bound allows
    bad = np.minimum(truth * rng.uniform(0.3, 1.7, truth.shape), 1.0)  # 70 % errors below the bound
    scene_white = float(np.percentile(truth, 98))
    crf = crf_models.get("linear")
    white, note = reachable_white(scene_white, crf, [0, 100], [10_000, 110_000])
    assert white == 1.0 and "min(scene white 300 x" in note
    # the scene's white maps every reachable output below 1/300: the two methods tie within 1e-4
    assert abs(mse01(bad, truth, scene_white) - mse01(good, truth, scene_white)) < 1e-4
    # the reachable white tells them apart
    assert mse01(bad, truth, white) > 0.01 > 1000 * mse01(good, truth, white)
    assert ssim01(good, truth, white) - ssim01(bad, truth, white) > 0.2
    # frames of a shorter exposure represent more (frames-only outputs CRF^-1(1) T_0 / T_k): the bound rises
    assert white_cap(crf, [0, 100_000], [10_000, 102_500]) == pytest.approx(4.0)
    assert reachable_white(0.5, crf, [0], [10_000])[0] == 0.5  # a dim scene keeps its own white


def test_reference_protocol_uses_the_reachable_white_and_says_so(tiny_dataset):
    rec = load(tiny_dataset / "a.h5")
    case, notes = recording_case(rec)
    scene_white = rec.metadata["reference_white_radiance"] * rec.metadata["reference_to_crf_x"]
    crf = crf_models.get(rec.crf["name"], **rec.crf["params"])
    assert case.white == pytest.approx(min(scene_white, max(1.0, float(crf.inverse(1.0)))))
    assert any(n.startswith(f"white {case.white:.4g} x = min(scene white") for n in notes)


# ----- pixel and time classes --------------------------------------------------------------------------------------

def _hand_made_case():
    """Two 8-bit frames 10 ms apart (linear CRF); columns 0-7 black in the first frame, 8-15 well-exposed, 16-23
    saturated in the second frame only; the truth flat in rows 0-7 and a random texture in rows 8-15."""
    h, w = 16, 24
    f0 = np.full((h, w), 128, np.uint8)
    f1 = f0.copy()
    f1[:, 16:] = 255
    f0[:, :8] = 1  # within CLIP_MARGIN_DN of black
    truth = np.full((1, h, w), 0.5)
    truth[0, 8:] = np.random.default_rng(1).uniform(0.1, 0.6, (8, w))
    case = Case(np.zeros(0, EVENT_DTYPE), np.stack([f0, f1]), np.array([0, 10_000]), np.array([1000, 11_000]),
                8, "linear", 0.2, np.array([5000]), truth, 1.0)
    return case, truth


def test_pixel_classes_split_a_hand_made_case():
    case, truth = _hand_made_case()
    masks = case.classes(0)
    cols = np.arange(truth.shape[2])[None, :].repeat(truth.shape[1], 0)
    np.testing.assert_array_equal(masks["high"], cols >= 16)  # clipped in either nearest frame
    np.testing.assert_array_equal(masks["low"], cols < 8)
    np.testing.assert_array_equal(masks["well"], (cols >= 8) & (cols < 16))
    assert masks["flat"][:5].all() and not masks["flat"][11:].any()  # 7x7 windows inside the flat half are flat
    np.testing.assert_array_equal(masks["textured"], ~masks["flat"])
    assert masks["between"].all() and not masks["at_frames"].any()  # 5000 us lies between the two exposures
    # an output wrong only where the frames clipped high: only the high class carries error
    out = truth.copy()
    out[0][masks["high"]] += 0.3
    scores = case.scores(out, slice(None), ("mse01", "ssim01", "psnr"), by_class=True)
    assert scores["mse01@high"] == pytest.approx(0.09)
    assert scores["mse01@well"] == 0 and scores["mse01@low"] == 0
    assert scores["mse01"] == pytest.approx(0.09 / 3)
    assert scores["share@high"] == scores["share@low"] == scores["share@well"] == pytest.approx(1 / 3)
    assert scores["ssim01@low"] == pytest.approx(1.0)  # SSIM windows there do not reach the wrong columns
    assert scores["ssim01@well"] > scores["ssim01@high"]
    # SSIM classes average the local SSIM map inside skimage's border, as ssim01 does
    smap = score_map("ssim01", out[0], truth[0], 1.0)
    assert scores["ssim01"] == pytest.approx(smap[3:-3, 3:-3].mean())
    assert scores["ssim01@high"] == pytest.approx(smap[3:-3, 16:-3].mean())
    assert "psnr@high" not in scores  # not a mean over pixels: no class split


# ----- the truth against the frames' range, and log_rmse pooled -------------------------------------------------

WINDOW_CRF = {"base": "gamma", "base_params": {"gamma": 2.2}, "low": 100.0, "high": 160.0, "levels": 255.0}


def _range_case(truth):
    """Two 8-bit frames behind the AKF paper's window CRF (x from 0.128 to 0.359 per unit exposure), exposed 1000
    and 500 us (gains T_0 / T_k of 1 and 2), scored at len(truth) times between them."""
    crf = crf_models.get("window", **WINDOW_CRF)
    frames = np.full((2, *truth.shape[1:]), 128, np.uint8)
    times = np.linspace(2000, 9000, truth.shape[0]).astype(np.int64)
    return Case(np.zeros(0, EVENT_DTYPE), frames, np.array([0, 10_000]), np.array([1000, 10_500]), 8, crf, 0.2,
                times, truth, 1.0), crf


def test_range_classes_split_the_truth_at_the_frames_floor_and_top_and_cover_every_pixel_once():
    crf = crf_models.get("window", **WINDOW_CRF)
    lo, hi = float(crf.inverse(0.0)), 2 * float(crf.inverse(1.0))  # the 500 us frame records up to twice as bright
    rng = np.random.default_rng(3)
    truth = np.exp(rng.uniform(np.log(lo / 20), np.log(hi * 20), (3, 12, 18)))
    truth[0, 0, :3] = (lo, hi, 0.0)  # the ends of the range are inside it; black is below
    case, _ = _range_case(truth)
    assert case.frames_range == pytest.approx((lo, hi), rel=1e-12)
    for k in range(truth.shape[0]):
        masks = case.classes(k)
        stacked = np.stack([masks[c] for c in RANGE_CLASSES])
        np.testing.assert_array_equal(stacked.sum(axis=0), 1)  # a partition: every pixel in exactly one class
        np.testing.assert_array_equal(masks["below_range"], truth[k] < lo)
        np.testing.assert_array_equal(masks["above_range"], truth[k] > hi)
        assert all(masks[c].any() for c in RANGE_CLASSES)
    assert case.classes(0)["in_range"][0, :2].all() and case.classes(0)["below_range"][0, 2]


def test_log_rmse_of_a_class_is_the_root_of_its_pooled_mean_square():
    crf = crf_models.get("window", **WINDOW_CRF)
    hi = 2 * float(crf.inverse(1.0))
    truth = np.full((2, 12, 18), 0.2)  # inside the range
    truth[:, :, 12:] = 3 * hi  # above it, on a third of the pixels
    case, _ = _range_case(truth)
    out = truth.copy()
    out[0][:, 12:] *= np.exp(0.2)  # a log error of 0.2 above the range in the first frame, 0.6 in the second
    out[1][:, 12:] *= np.exp(-0.6)
    scores = case.scores(out, slice(None), ("log_rmse",), by_class=True)
    assert scores["share@above_range"] == pytest.approx(1 / 3) and scores["share@below_range"] == 0
    assert scores["log_rmse@above_range"] == pytest.approx(np.sqrt((0.2**2 + 0.6**2) / 2), rel=1e-9)  # not 0.4
    assert scores["log_rmse@in_range"] == 0.0 and np.isnan(scores["log_rmse@below_range"])
    # the sequence's log_rmse pools the frames too: sqrt((0.04 + 0.36) / 6), not the mean of the frames' RMSEs
    assert scores["log_rmse"] == pytest.approx(np.sqrt((0.2**2 + 0.6**2) / 6), rel=1e-9)
    assert scores["log_rmse"] == pytest.approx(np.sqrt(np.mean(score_map("log_rmse", out[0], truth[0], top=hi))
                                                       / 2 + np.mean(score_map("log_rmse", out[1], truth[1], top=hi))
                                                       / 2), rel=1e-12)


def test_the_mean_over_sequences_of_log_rmse_is_the_root_mean_square():
    nan = float("nan")
    table = add_means({"akf": {"a": {"log_rmse": 0.3, "log_rmse@high": 0.1, "mse": 1.0},
                               "b": {"log_rmse": 0.4, "log_rmse@high": nan, "mse": 3.0}}})
    mean = table["akf"]["mean"]
    assert mean["log_rmse"] == pytest.approx(np.sqrt((0.09 + 0.16) / 2), rel=1e-12)
    assert mean["log_rmse@high"] == pytest.approx(0.1) and mean["mse"] == 2.0


def test_default_metrics_lead_with_full_range_scores_against_an_hdr_reference():
    assert request_defaults("reference") == (DEFAULT_METRICS["reference"], "log_rmse")
    assert DEFAULT_METRICS["reference"][:3] == ("log_rmse", "pu21_psnr", "pu21_ssim")
    assert request_defaults("interleave") == (DEFAULT_METRICS["interleave"], "mse01")
    assert DEFAULT_METRICS["interleave"][:2] == ("mse01", "ssim01")  # the held-out truth is clipped already
    assert request_defaults("interleave", ("mse",), "ssim01") == (("mse",), "ssim01")
    with pytest.raises(sim.EvsimInputError, match="unknown protocol 'hdr'"):
        request_defaults("hdr")


def test_the_default_table_and_json_hold_every_figure(tiny_dataset, tmp_path, capsys):
    js = tmp_path / "s.json"
    assert main(["evaluate", str(tiny_dataset), "--methods", "frames,akf", "--json", str(js)]) == 0
    text = capsys.readouterr().out
    blocks = [line.split(":")[0] for line in text.splitlines() if line.split(":")[0] in evsim_eval.METRICS]
    assert blocks == list(DEFAULT_METRICS["reference"])  # one block per metric, in the headline order
    assert "mse01 (clipped)" in text and "log_rmse by class" in text and "truth above the frames' top" in text
    data = json.loads(js.read_text())
    per_pixel = [m for m in DEFAULT_METRICS["reference"] if m in evsim_eval.metrics.PER_PIXEL]
    expected = {*DEFAULT_METRICS["reference"], *(f"{m}@{c}" for m in per_pixel for c in CLASSES),
                *(f"share@{c}" for c in CLASSES)}
    for method in ("frames", "akf"):
        assert set(data[method]["a"]) == set(data[method]["mean"]) == expected
    assert data["frames"]["a"]["log_rmse"] > data["akf"]["a"]["log_rmse"] > 0
    assert "frames' top" in data["scoring"]["frames_top"]
    assert any("log_rmse floor" in n for n in data["scoring"]["notes"])


# ----- scores between frames ---------------------------------------------------------------------------------------

def test_reference_frames_between_frames_are_scored_and_frames_only_is_worse_there(blurred):
    rec, _ = blurred  # references at 100 Hz, frames at 30 Hz of 20 ms
    table, _ = evaluate_recording(rec, methods=("frames", "akf"), metrics=("mse01",), by_class=True)
    frames = table["frames"]
    assert 0 < frames["share@between"] < 1 and frames["share@at_frames"] + frames["share@between"] == 1
    # the moving edge has moved away from where the last frame saw it: frames-only is worse between frames
    assert frames["mse01@between"] > 1.5 * frames["mse01@at_frames"]
    assert table["akf"]["mse01@between"] < frames["mse01@between"]  # the events tell where the edge went


def test_evaluate_dataset_reports_classes_and_json_writes_null_for_empty_ones(tiny_dataset, tmp_path, capsys):
    result = evaluate_dataset(tiny_dataset, methods=("frames",), metrics=("mse01", "ssim01")).table
    assert {"mse01@well", "ssim01@high", "share@between"} <= set(result["frames"]["mean"])
    js = tmp_path / "s.json"
    assert main(["evaluate", str(tiny_dataset), "--methods", "frames", "--metrics", "mse01", "--json", str(js)]) == 0
    text = capsys.readouterr().out
    assert "mse01 (clipped) by class" in text and "well-exposed in both nearest input frames" in text
    data = json.loads(js.read_text())
    assert data["scoring"]["protocol"] == "reference" and "white" in data["scoring"]
    assert data["frames"]["a"]["mse01@well"] == pytest.approx(result["frames"]["a"]["mse01@well"], rel=1e-12)
