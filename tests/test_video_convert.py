"""Videos as scenes (generators.scenes.video, flow_interpolation) and `evsim convert` (generators.convert).

The ground truth: a built-in scene rendered at 1 kHz is the truth; every 33rd frame is a 30 fps "video"; the
events of the converted video are compared with those of the full-rate frames.
"""

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

import crf_models
import sim
from evsim_app.cli import main
from generators.ahdr import AHDRConfig, generate_ahdr
from generators.config import build_scene, parse_config, to_ahdr_config
from generators.convert import clips, convert, convert_config
from generators.formats import DatasetFormatError, load
from generators.sampling import AdaptiveSampler, FixedRateSampler
from generators.scenes import FrameSequenceScene, Trajectory, VideoScene, builtin_image_scene
from generators.scenes.flow_interpolation import FlowEstimator

VIDEO_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "video"
H, W, FULL_STEP_US, KEEP = 48, 64, 1000, 33


def _write_video(path, frames, fps=30.0):
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (frames.shape[2], frames.shape[1]))
    for f in frames:
        w.write(np.dstack([f, f, f]))
    w.release()
    return path


def _texture(h, w, seed=0):
    """A smooth random texture, float32 in about [0.05, 1]."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 2.0)
    return (0.05 + 0.95 * (t - t.min()) / (t.max() - t.min())).astype(np.float32)


# ----- ground truth -------------------------------------------------------------------------------------

def _counts(ev):
    return np.bincount(ev["y"].astype(np.int64) * W + ev["x"], minlength=H * W)


def _rate(ev, end_us, bin_us=15_000):
    return np.histogram(ev["t"], bins=np.arange(0, end_us + 1, bin_us))[0]


def test_converted_video_matches_the_events_of_the_full_rate_frames(tmp_path):
    duration = 500_000
    scene = builtin_image_scene(H, W, duration, Trajectory(pan_px_per_s=(60.0, 20.0), shake_px=1.5, shake_hz=3.0))
    times = np.arange(0, duration + 1, FULL_STEP_US, dtype=np.int64)
    frames = np.stack([scene.radiance(int(t)) for t in times])  # the truth at 1 kHz
    np.save(tmp_path / "clip.npy", frames[::KEEP])  # a 30.3 fps float (linear) video
    end = int(times[::KEEP][-1])
    fps = 1e6 / (KEEP * FULL_STEP_US)

    settings = {"sensor": "ideal"}
    truth_cfg = to_ahdr_config(convert_config(tmp_path / "clip.npy", settings=settings, fps=fps).sequences[0].settings)
    generate_ahdr(FrameSequenceScene(frames[times <= end], times[times <= end]), tmp_path / "truth.h5", truth_cfg,
                  0, progress=False)
    truth = load(tmp_path / "truth.h5").events

    scores = {}
    for mode in ("linear", "flow"):
        convert(tmp_path / "clip.npy", tmp_path / mode, settings=settings, fps=fps, upsample=mode, progress=False)
        ev = load(tmp_path / mode / "clip.h5").events
        scores[mode] = {"count_ratio": ev.size / truth.size,
                        "pixel_corr": float(np.corrcoef(_counts(ev), _counts(truth))[0, 1]),
                        "rate_corr": float(np.corrcoef(_rate(ev, end), _rate(truth, end))[0, 1])}
    print(f"\n{truth.size} events at 1 kHz; converted from 30 fps: {json.dumps(scores, indent=1)}")
    flow, linear = scores["flow"], scores["linear"]
    assert abs(flow["count_ratio"] - 1) <= 0.10
    assert flow["pixel_corr"] >= 0.9
    assert flow["rate_corr"] >= 0.9
    # motion-compensated upsampling beats the cross-fade on all three
    assert abs(flow["count_ratio"] - 1) < abs(linear["count_ratio"] - 1)
    assert flow["pixel_corr"] > linear["pixel_corr"]
    assert flow["rate_corr"] > linear["rate_corr"]


@pytest.mark.parametrize("scale", [1.0, 0.5])  # flow at full size, and at half size with vectors scaled back
def test_flow_interpolation_moves_a_texture_where_the_cross_fade_blends_it(scale):
    tex = np.log(_texture(64, 96))
    shift = 4.0  # pixels per interval, to the right
    warp = lambda img, dx: cv2.warpAffine(img, np.float32([[1, 0, dx], [0, 1, 0]]), (96, 64),
                                          flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT_101)
    log0, log1, mid = tex, warp(tex, shift), warp(tex, shift / 2)
    pair = FlowEstimator((float(tex.min()), float(tex.max())), scale=scale).pair(log0, log1)
    inner = (slice(8, -8), slice(8, -8))
    flow_err = np.abs(pair.log_at(0.5) - mid)[inner].mean()
    fade_err = np.abs(0.5 * (log0 + log1) - mid)[inner].mean()
    assert pair.n_keys == pytest.approx(2 * shift, abs=1)  # a key every half pixel of motion
    assert np.median(pair.flow01[..., 0][inner]) == pytest.approx(shift, abs=0.1)
    assert flow_err < 0.25 * fade_err
    np.testing.assert_array_equal(pair.log_at(0.0), log0)
    np.testing.assert_array_equal(pair.log_at(1.0), log1)
    # continuous in time: a microsecond-sized step gives a proportionally small change
    assert np.abs(pair.log_at(0.3001) - pair.log_at(0.3)).max() < 1e-2
    # fast motion: at most max_keys key intervals, spaced further apart, same ends
    capped = FlowEstimator((float(tex.min()), float(tex.max())), scale=scale).pair(log0, log1, max_keys=3)
    assert capped.n_keys == 3
    np.testing.assert_array_equal(capped.log_at(1.0), log1)
    assert np.abs(capped.log_at(0.5) - mid)[inner].mean() < 0.5 * fade_err


def test_occlusion_marks_content_that_leaves_the_view():
    tex = np.log(_texture(48, 64, seed=1))
    log1 = np.roll(tex, 6, axis=1)  # content moves right; the leftmost columns of frame 1 are new
    pair = FlowEstimator((float(tex.min()), float(tex.max()))).pair(tex, log1)
    assert pair.occlusion0[8:-8, -4:].mean() > 0.8  # leaves the view at the right
    assert pair.occlusion0[8:-8, 16:-16].mean() < 0.1


# ----- inputs, linearisation, geometry --------------------------------------------------------------------

def test_image_folder_16_bit_png_with_timestamps_in_seconds_is_linearised_through_the_inverse_crf(tmp_path):
    levels = np.array([1000, 20000, 40000, 65535], dtype=np.uint16)
    for i, v in enumerate(levels):
        img = np.full((12, 16, 3), v, np.uint16)
        img[..., 0] = 0  # a colour image: red 0 (OpenCV writes BGR, so this is the blue channel)
        cv2.imwrite(str(tmp_path / f"f{i:03d}.png"), img)
    (tmp_path / "timestamps.txt").write_text("0.0\n0.04\n0.1\n0.15\n")
    for crf in ("srgb", "gamma"):
        scene = VideoScene(tmp_path, input_crf=crf, upsample="none")
        assert scene.times.tolist() == [0, 40_000, 100_000, 150_000]
        lin = crf_models.get(crf).inverse(levels / 65535.0)
        expected = (0.2126 + 0.7152) * lin  # R, G at the level, B at 0
        for t, e in zip(scene.times, expected):
            assert scene.radiance(int(t)) == pytest.approx(np.full((12, 16), e, np.float32), rel=1e-5)
        meta = scene.describe()
        assert meta["linearisation"]["crf"]["name"] == crf
        assert meta["input"]["timestamps"].endswith("timestamps.txt") and meta["input"]["unit"] == "s"


def test_rec709_luminance_is_colour_science_bt709_y():
    colour = pytest.importorskip("colour")
    y_row = colour.RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ[1]
    from generators.scenes import REC709_WEIGHTS

    np.testing.assert_allclose(REC709_WEIGHTS, y_row, atol=1e-4)


def test_hdr_stack_is_cropped_to_the_sensor_aspect_and_area_integrated(tmp_path):
    # 40 x 120 input, 10 x 10 sensor: the centred 40 x 40 window, each output pixel the mean of a 4 x 4 block
    rng = np.random.default_rng(3)
    stack = rng.random((3, 40, 120)).astype(np.float32)
    np.save(tmp_path / "s.npy", stack)
    scene = VideoScene(tmp_path / "s.npy", fps=10.0, height=10, width=10, upsample="linear")
    expected = stack[1][:, 40:80].reshape(10, 4, 10, 4).mean(axis=(1, 3))
    np.testing.assert_allclose(scene.radiance(100_000), expected, rtol=1e-5)
    assert scene.describe()["crop"] == [0, 40, 40, 80]
    assert "float input taken as linear" in scene.describe()["linearisation"]["method"]
    # one size alone keeps the aspect ratio
    assert (VideoScene(tmp_path / "s.npy", fps=10.0, height=20).width) == 60


def test_start_stop_and_the_sliding_window(tmp_path):
    stack = np.stack([_texture(24, 32, seed=i) for i in range(12)])
    np.save(tmp_path / "s.npy", stack)
    scene = VideoScene(tmp_path / "s.npy", fps=20.0, start_s=0.1, stop_s=0.4)  # frames 2..8
    assert scene.duration_us == 300_000 and scene.times.size == 7
    np.testing.assert_allclose(scene.radiance(0), stack[2], rtol=1e-5)
    first = [scene.radiance(t) for t in range(0, scene.duration_us + 1, 7000)]
    assert len(scene._window) <= 3 and len(scene._pairs) <= 2  # memory does not grow with the clip
    np.testing.assert_allclose(scene.radiance(scene.duration_us), stack[8], rtol=1e-5)
    again = [scene.radiance(t) for t in range(0, scene.duration_us + 1, 7000)]  # going back decodes again
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    assert scene.max_speed_px_per_s() > 0


def test_video_file_and_config_scene_type(tmp_path):
    tex = (255 * _texture(48, 64)).astype(np.uint8)
    frames = np.stack([np.roll(tex, k, axis=1) for k in range(0, 20, 2)])  # 2 px per frame, 30 fps
    _write_video(tmp_path / "clip.avi", frames)
    cfg = parse_config({"defaults": {"height": 24, "width": 32},
                        "sequence": [{"name": "c", "scene": {"type": "video", "path": "clip.avi", "stop_s": 0.2}}]},
                       base_dir=tmp_path)
    spec = cfg.sequences[0]
    scene = build_scene(spec.scene, 24, 32, spec.duration_us)
    assert (scene.height, scene.width, scene.duration_us) == (24, 32, round(6e6 / 30))
    meta = scene.describe()
    assert meta["input"]["sha256"] == hashlib.sha256((tmp_path / "clip.avi").read_bytes()).hexdigest()
    assert meta["capture_fps"] == pytest.approx(30.0)
    # 2 px per frame at 64 wide is 1 px per frame at 32 wide: 30 px/s
    assert scene.max_speed_px_per_s() == pytest.approx(30.0, rel=0.3)


def test_the_sampler_feeds_the_dvs_exactly_the_log_linear_pieces(tmp_path):
    from generators.sampling import AdaptiveSampler

    stack = np.stack([np.full((8, 8), 10.0 ** k, np.float32) for k in range(4)])  # x10 per frame: far above the bound
    np.save(tmp_path / "s.npy", stack)
    kw = dict(threshold=0.2, fraction=0.5, max_step_us=1_000_000, log_eps=1e-6)
    linear = VideoScene(tmp_path / "s.npy", fps=10.0, upsample="linear")
    assert [t for t, _ in AdaptiveSampler(linear, **kw)] == linear.times.tolist()  # the frames and nothing else
    hold = VideoScene(tmp_path / "s.npy", fps=10.0, upsample="none")
    samples = [(t, float(img[0, 0])) for t, img in AdaptiveSampler(hold, **kw)]
    assert samples == [(0, 1.0), (99_999, 1.0), (100_000, 10.0), (199_999, 10.0), (200_000, 100.0),
                       (299_999, 100.0), (300_000, 1000.0)]  # held, then switched within a microsecond


# ----- bad input ---------------------------------------------------------------------------------------

def test_bad_inputs_get_clear_errors(tmp_path):
    (tmp_path / "garbage.mp4").write_bytes(b"not a video" * 100)
    with pytest.raises(DatasetFormatError, match="cannot open as a video"):
        VideoScene(tmp_path / "garbage.mp4")
    w = cv2.VideoWriter(str(tmp_path / "empty.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30, (64, 48))
    w.release()
    with pytest.raises(DatasetFormatError, match="no frames"):
        VideoScene(tmp_path / "empty.avi")
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    cv2.imwrite(str(mixed / "a.png"), np.zeros((10, 12), np.uint8))
    cv2.imwrite(str(mixed / "b.png"), np.zeros((10, 14), np.uint8))
    with pytest.raises(DatasetFormatError, match="different sizes"):
        VideoScene(mixed, fps=10)
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"{i}.png"), np.full((10, 12), 100, np.uint8))
    (folder / "timestamps.txt").write_text("0\n50000\n40000\n")
    with pytest.raises(DatasetFormatError, match="increase strictly.*line 3"):
        VideoScene(folder)
    (folder / "timestamps.txt").write_text("0\n50000\n90000\n")
    with pytest.raises(sim.InvalidParameterError, match="before stop_s"):
        VideoScene(folder, start_s=0.08, stop_s=0.05)
    with pytest.raises(sim.EvsimInputError, match="0 input frame"):
        VideoScene(folder, start_s=1.0)
    with pytest.raises(sim.InvalidParameterError, match="max_keys"):
        VideoScene(folder, max_keys=0)
    with pytest.raises(sim.EvsimInputError, match="holds both videos and images"):
        _write_video(folder / "v.avi", np.zeros((2, 10, 12), np.uint8))
        clips(folder)
    stack = np.ones((4, 10, 12), np.float32)
    stack[2, 3, 4] = np.nan  # VideoScene checks its frames as they are decoded, not its renders (renders_finite)
    np.save(tmp_path / "nan.npy", stack)
    scene = VideoScene(tmp_path / "nan.npy", fps=10)
    assert np.all(np.isfinite(scene.radiance(50_000)))  # frames 0 and 1
    with pytest.raises(DatasetFormatError, match="frame 2: image holds NaN"):
        scene.radiance(150_000)


def test_cli_reports_bad_input_with_exit_code_2(tmp_path, capsys):
    (tmp_path / "garbage.mp4").write_bytes(b"junk")
    assert main(["convert", str(tmp_path / "garbage.mp4"), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    assert "garbage.mp4: cannot open as a video" in capsys.readouterr().err


# ----- the real clips end to end ---------------------------------------------------------------------------

@pytest.mark.skipif(not VIDEO_DIR.is_dir(), reason="../shared/data/video is absent")
def test_real_clips_convert_end_to_end(tmp_path, capsys):
    videos = sorted(VIDEO_DIR.glob("*.mp4"))
    if not videos:
        pytest.skip("no .mp4 clips in ../shared/data/video")
    out = tmp_path / "out"
    assert main(["convert", str(VIDEO_DIR), "--out", str(out), "--stop-s", "0.25", "--height", "40",
                 "--sensor", "davis346", "--crf", "srgb", "--format", "e2vid", "--no-progress",
                 "--outputs", "events,frames,reference"]) == 0
    index = json.loads((out / "index.json").read_text())
    assert [s["name"] for s in index["sequences"]] == [v.stem for v in videos]
    for entry, video in zip(index["sequences"], videos):
        rec = load(out / entry["file"])
        assert rec.height == 40 and rec.events.size > 1000
        assert len(rec.frames) >= 6 and len(rec.reference) >= 6
        meta = rec.metadata["scene"]
        assert meta["input"]["sha256"] == hashlib.sha256(video.read_bytes()).hexdigest()
        assert meta["upsample"]["mode"] == "flow" and meta["linearisation"]["crf"]["name"] == "srgb"
        assert (out / entry["export"]).is_file()
        capsys.readouterr()
        assert main(["info", str(out / entry["file"])]) == 0
        assert "events" in capsys.readouterr().out
    pytest.importorskip("matplotlib")
    figure = tmp_path / "events.png"
    assert main(["plot", "events", str(out / index["sequences"][0]["file"]), "--out", str(figure)]) == 0
    assert figure.stat().st_size > 0


def test_keys_stay_at_or_above_the_log_of_black_where_the_upsampling_overshoots(tmp_path):
    """A bright square moving on black (radiance 0): the bicubic 4x copies ring below the frames' darkest value, and
    the keys are the log the DVS is fed (DVSEmulator.feed_log), whose floor is log(radiance 0 + log_eps)."""
    frames = np.zeros((6, 40, 56), np.float32)
    for i in range(6):
        frames[i, 12:24, 8 + 5 * i:20 + 5 * i] = 50.0
    np.save(tmp_path / "square.npy", frames)
    scene = VideoScene(tmp_path / "square.npy", fps=20)
    floor = np.log(np.float32(scene.log_eps))
    logs = [scene.offset_log(t, scene.log_eps) for t in range(0, scene.duration_us + 1, 2500)]
    assert min(float(v.min()) for v in logs) >= floor
    assert np.isclose(min(float(v.min()) for v in logs), floor)
    out = tmp_path / "square.h5"
    r = generate_ahdr(scene, out, AHDRConfig(outputs=("events",), crf="srgb"), 0, progress=False)
    assert r.n_events > 100


def test_samplers_yield_the_log_a_video_holds_and_refuse_it_elsewhere(tmp_path):
    frames = np.stack([np.full((10, 12), 1.0 + i, np.float32) for i in range(4)])
    frames[:, 2:5, 3:7] *= 5.0
    np.save(tmp_path / "clip.npy", frames)
    scene = VideoScene(tmp_path / "clip.npy", fps=10, upsample="linear")
    eps = scene.log_eps
    for sampler in (AdaptiveSampler(scene, threshold=0.2, log_offset=eps),
                    FixedRateSampler(scene, rate_hz=40.0, log_offset=eps)):
        samples = list(sampler)
        assert len(samples) > 4
        for t, log in samples:
            np.testing.assert_allclose(log, np.log(scene.radiance(t) + np.float32(eps)), rtol=0, atol=2e-6)
    assert not scene.has_log_at(2 * eps)  # another offset: computed from the radiance
    with pytest.raises(sim.EvsimInputError, match="outside the source's time range"):
        scene.offset_log(scene.duration_us + 1, eps)
    np.testing.assert_allclose(scene.offset_log(50_000, 2 * eps), np.log(scene.radiance(50_000) + np.float32(2 * eps)))
    still = builtin_image_scene(10, 12, 100_000, Trajectory())
    with pytest.raises(sim.InvalidParameterError, match="log-linear"):
        AdaptiveSampler(still, threshold=0.2, log_offset=eps)
    with pytest.raises(sim.InvalidParameterError, match="has no offset_log"):
        FixedRateSampler(still, rate_hz=40.0, log_offset=eps)
