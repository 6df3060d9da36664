"""What a video's frames mean before the DVS sees them: the capture rate of slow-motion clips (metadata, --slowmo,
--input-fps), the resize policy, and the input conditioning against codec artefacts and read noise
(generators.scenes.video, capture_rate, conditioning).

Ground truth: synthetic clips whose capture rate, geometry and clean frames are known; the real DAVIS346 frames of
../shared/data/events/davis346_road (skipped when absent).
"""

import json
import struct
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
from video_clips import H, W, encode_mp4, slow_motion_frames, tag_capture_fps

from evsim_app.cli import main
from generators.config import build_scene, load_config
from generators.convert import convert
from generators.formats import DatasetFormatError, load
from generators.scenes import VideoScene
from generators.scenes.capture_rate import capture_fps
from generators.scenes.conditioning import ConditioningParams, InputConditioner
from generators.scenes.video import InputTimingWarning
from sim import EvsimInputError, InvalidParameterError

ROAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "events" / "davis346_road" / "ijrr"
N_SLOW = 96  # frames of the short slow-motion clip: 0.1 s at 960 fps, 3.2 s at 30


@pytest.fixture(scope="module")
def slow_clip(tmp_path_factory):
    """A 960 fps capture stored at 30 fps (MP4), untagged."""
    return encode_mp4(tmp_path_factory.mktemp("slow") / "slow.mp4", slow_motion_frames(N_SLOW), gop=48)


def _tagged(src: Path, dst: Path, fps: float, **kw) -> Path:
    dst.write_bytes(src.read_bytes())
    tag_capture_fps(dst, fps, **kw)
    return dst


# ----- capture rate -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("where", ["moov", "udta"])
def test_capture_fps_metadata_gives_the_true_duration(slow_clip, tmp_path, where):
    clip = _tagged(slow_clip, tmp_path / "tagged.mp4", 960.0, where=where)
    assert capture_fps(clip) == (960.0, "com.android.capture.fps")
    scene = VideoScene(clip, upsample="none")
    assert scene.duration_us == round((N_SLOW - 1) * 1e6 / 960)  # 99 ms, not 3.17 s
    meta = scene.describe()
    assert meta["capture_fps"] == pytest.approx(960.0, rel=1e-4)
    assert meta["input"]["container_fps"] == pytest.approx(30.0)
    assert "capture-rate metadata" in meta["input"]["from"]


def test_slowmo_flag_without_metadata_gives_the_same_times(slow_clip, tmp_path):
    assert capture_fps(slow_clip) is None
    tagged = VideoScene(_tagged(slow_clip, tmp_path / "tagged.mp4", 960.0), upsample="none")
    flagged = VideoScene(slow_clip, upsample="none", slowmo=32)
    assert np.array_equal(flagged.times, tagged.times)
    assert flagged.describe()["input"]["from"] == "container rate x slowmo 32"
    assert VideoScene(slow_clip, upsample="none").duration_us == round((N_SLOW - 1) * 1e6 / 30)


def test_metadata_contradicting_the_given_rate_warns_in_one_line(slow_clip, tmp_path):
    clip = _tagged(slow_clip, tmp_path / "tagged.mp4", 960.0)
    with pytest.warns(InputTimingWarning, match=r"captured at 960 fps .* but 30 fps is used") as w:
        scene = VideoScene(clip, upsample="none", fps=30)
    assert "\n" not in str(w[0].message)
    assert scene.capture_fps == pytest.approx(30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        VideoScene(clip, upsample="none", slowmo=32)  # agrees: no warning


def test_slowmo_refuses_a_second_rate_and_inputs_without_a_container_rate(slow_clip, tmp_path):
    with pytest.raises(EvsimInputError, match="slowmo cannot be combined with fps"):
        VideoScene(slow_clip, slowmo=32, fps=960)
    np.save(tmp_path / "s.npy", slow_motion_frames(3))
    with pytest.raises(EvsimInputError, match="slowmo applies to video files"):
        VideoScene(tmp_path / "s.npy", slowmo=32, fps=30)


def test_implausibly_small_motion_at_the_container_rate_warns(slow_clip, capsys):
    scene = VideoScene(slow_clip, height=60, width=80)  # flow: the motion is measured
    with pytest.warns(InputTimingWarning, match=r"moves only 0\.\d\d px per frame .*give slowmo=FACTOR or fps") as w:
        scene.max_speed_px_per_s()
    assert "--" not in str(w[0].message) and w[0].message.cli_message.endswith("give --slowmo FACTOR or --input-fps")
    from evsim_app.cli import _note  # the command line prints it in its flags

    _note(w[0].message, InputTimingWarning, "video.py", 1)
    assert capsys.readouterr().err == f"evsim: note: {w[0].message.cli_message}\n"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        VideoScene(slow_clip, height=60, width=80, slowmo=32).max_speed_px_per_s()  # rate given: no guess


def test_capture_rate_parser_is_strict(slow_clip, tmp_path):
    clip = _tagged(slow_clip, tmp_path / "tagged.mp4", 960.0)
    buf = bytearray(clip.read_bytes())
    k = buf.rindex(b"keys")
    buf[k + 8:k + 12] = struct.pack(">I", 5)  # five keys announced, one present
    (tmp_path / "bad.mp4").write_bytes(bytes(buf))
    with pytest.raises(DatasetFormatError, match=r"bad\.mp4: moov/meta/keys: 5 keys announced"):
        capture_fps(tmp_path / "bad.mp4")
    buf = bytearray(clip.read_bytes())
    m = buf.rindex(b"moov") - 4
    buf[m:m + 4] = struct.pack(">I", len(buf))  # the movie box runs past the end of the file
    (tmp_path / "long.mp4").write_bytes(bytes(buf))
    with pytest.raises(DatasetFormatError, match="runs past the end of the file"):
        capture_fps(tmp_path / "long.mp4")
    (tmp_path / "x.avi").write_bytes(b"RIFF\0\0\0\0AVI LIST")
    assert capture_fps(tmp_path / "x.avi") is None


# ----- resize policy ----------------------------------------------------------------------------------------

def test_resize_policies_on_a_portrait_clip(tmp_path):
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(20, 235, (160, 90)).astype(np.uint8), (0, 0), 2)  # portrait, 90 x 160
    stack = np.stack([img, img])
    np.save(tmp_path / "portrait.npy", stack)
    lin = VideoScene(tmp_path / "portrait.npy", fps=30, upsample="none").radiance(0)  # linear, input size
    area = lambda a, h, w: cv2.resize(a, (w, h), interpolation=cv2.INTER_AREA)  # noqa: E731
    crop = VideoScene(tmp_path / "portrait.npy", fps=30, upsample="none", height=26, width=34)
    y0, y1, _, _ = crop.describe()["crop"]
    assert (y1 - y0, crop.describe()["resize"]["policy"]) == (round(90 * 26 / 34), "crop")  # 69 of 160 rows
    assert crop.radiance(0) == pytest.approx(area(lin[y0:y1], 26, 34), rel=1e-5)
    pad = VideoScene(tmp_path / "portrait.npy", fps=30, upsample="none", height=26, width=34, resize="pad")
    p0, p1, q0, q1 = pad.describe()["resize"]["placement"]
    assert (p0, p1, q1 - q0) == (0, 26, round(26 * 90 / 160))  # the whole frame, 15 px wide, centred
    r = pad.radiance(0)
    assert r[:, q0:q1] == pytest.approx(area(lin, 26, q1 - q0), rel=1e-5)
    assert not r[:, :q0].any() and not r[:, q1:].any()  # black bars
    stretch = VideoScene(tmp_path / "portrait.npy", fps=30, upsample="none", height=26, width=34, resize="stretch")
    assert stretch.radiance(0) == pytest.approx(area(lin, 26, 34), rel=1e-5)
    with pytest.raises(InvalidParameterError, match="resize must be one of crop, pad, stretch"):
        VideoScene(tmp_path / "portrait.npy", fps=30, resize="fit")


# ----- input conditioning -----------------------------------------------------------------------------------

def test_conditioning_holds_read_noise_and_passes_real_changes():
    rng = np.random.default_rng(1)
    truth = np.full((60, 80), 12.0, np.float32)  # a dark static scene, 12 DN
    cond = InputConditioner({"noise_dn": 1.6, "key_frames": False})
    outs = []
    for k in range(60):
        if k == 30:
            truth[:, 40:] += 40  # an edge arrives on the right half
        if k == 45:
            truth += 20  # a light switched on: a uniform change
        outs.append(cond(truth + rng.normal(0, 1.6, truth.shape).astype(np.float32)))
    outs = np.stack(outs)
    still = outs[1:30, :, :40]
    assert np.abs(np.diff(still, axis=0)).mean() < 0.02 * 1.6  # read noise held: 1.6 DN rms -> under 0.03 DN
    tau = 3 * 1.6
    assert np.abs(outs[31, :, 40:] - 52).max() < tau + 4 * 1.6  # the edge passed at once, less at most tau
    assert np.abs(outs[46] - truth).max() < tau + 4 * 1.6  # so did the light
    assert cond.stats()["key_frames"] == 0


def test_conditioning_estimates_the_noise_and_absorbs_key_frames(tmp_path):
    frames = slow_motion_frames(200, noise_dn=0.8)
    clip = encode_mp4(tmp_path / "gop.mp4", frames, gop=50)
    cap = cv2.VideoCapture(str(clip))
    decoded = []
    while (f := cap.read())[0]:
        decoded.append(cv2.cvtColor(f[1], cv2.COLOR_BGR2GRAY).astype(np.float32))
    decoded = np.stack(decoded)
    cond = InputConditioner()
    out = np.stack([cond(f) for f in decoded])
    assert {50, 100, 150} <= set(cond.stats()["first_key_frames"])  # the encoder's key frames, found
    static = (slice(None), slice(48, None))  # the disk moves along y = 20 (radius 8)
    step_in = np.abs(np.diff(decoded[static], axis=0))[[49, 99, 149]].mean()
    step_out = np.abs(np.diff(out[static], axis=0))[[49, 99, 149]].mean()
    assert step_in > 1.0 and step_out < 0.2 * step_in
    swept = np.abs(frames[120].astype(int) - frames[110]) > 50  # the disk's edges passed these since frame 110
    tau = 3 * cond.stats()["noise_dn_median"]
    assert swept.sum() > 50 and np.abs(out[120][swept] - decoded[120][swept]).max() <= tau + 1e-4  # no lag


def test_conditioning_options_are_checked():
    with pytest.raises(InvalidParameterError, match="unknown conditioning key 'noise'; allowed: mode, noise_dn"):
        ConditioningParams.from_option({"noise": 1.0})
    with pytest.raises(InvalidParameterError, match="threshold_sigmas must be a finite number > 0"):
        ConditioningParams(threshold_sigmas=0)
    assert ConditioningParams.from_option("off").mode == "off"


def _burst_and_static_rate(path: Path) -> tuple[float, float]:
    """(largest 10 ms event count over the median, event rate in Hz per pixel on the static rows y >= 48)."""
    ev = load(path).events
    counts = np.histogram(ev["t"], np.arange(0, ev["t"].max() - 10_000, 10_000))[0]
    static = ev["y"] >= 48
    return counts.max() / np.median(counts), static.sum() / ((H - 48) * W) / (ev["t"].max() / 1e6)


@pytest.mark.slow
def test_compressed_slow_motion_clip_gives_no_key_frame_bursts_and_clean_static_noise(tmp_path):
    """960 fps capture (0.8 DN camera noise) stored at 30 fps with a key frame every 160 frames (as the phone
    clip of the issue): against the same scene uncompressed and noise-free, davis346 preset."""
    encode_mp4(tmp_path / "clip.mp4", slow_motion_frames(480, noise_dn=0.8), gop=160)
    np.save(tmp_path / "clean.npy", slow_motion_frames(480))
    common = dict(upsample="linear", progress=False, settings={"sensor": "davis346"})
    convert(tmp_path / "clean.npy", tmp_path / "clean", fps=960, **common)
    convert(tmp_path / "clip.mp4", tmp_path / "raw", slowmo=32, conditioning="off", **common)
    convert(tmp_path / "clip.mp4", tmp_path / "cond", slowmo=32, **common)
    _, clean_rate = _burst_and_static_rate(tmp_path / "clean" / "clean.h5")
    raw_burst, raw_rate = _burst_and_static_rate(tmp_path / "raw" / "clip.h5")
    burst, rate = _burst_and_static_rate(tmp_path / "cond" / "clip.h5")
    assert raw_burst > 2.5 and raw_rate > 2.5 * clean_rate  # what the conditioning is for
    assert burst < 2.0
    assert rate < 2.0 * clean_rate


@pytest.mark.slow
def test_cli_converts_a_tagged_slow_motion_clip_to_its_true_duration(slow_clip, tmp_path, capsys):
    clip = _tagged(slow_clip, tmp_path / "tagged.mp4", 960.0)
    assert main(["convert", str(clip), "--out", str(tmp_path / "a"), "--upsample", "none", "--no-progress",
                 "--resize", "pad", "--height", "40", "--width", "40"]) == 0
    assert main(["convert", str(slow_clip), "--out", str(tmp_path / "b"), "--upsample", "none", "--no-progress",
                 "--slowmo", "32", "--height", "40", "--width", "40"]) == 0
    for folder in ("a", "b"):
        rec = load(tmp_path / folder / f"{'tagged' if folder == 'a' else 'slow'}.h5")
        assert rec.metadata["duration_us"] == round((N_SLOW - 1) * 1e6 / 960)
        assert rec.metadata["scene"]["capture_fps"] == pytest.approx(960, rel=1e-4)
        assert rec.crf["name"] == "srgb"
    assert load(tmp_path / "a" / "tagged.h5").metadata["scene"]["resize"]["policy"] == "pad"
    assert json.loads((tmp_path / "a" / "index.json").read_text())["sequences"]
    capsys.readouterr()
    assert main(["convert", str(clip), "--out", str(tmp_path / "c"), "--upsample", "none", "--no-progress",
                 "--input-fps", "30", "--height", "20", "--width", "20"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["evsim: note: tagged.mp4: its metadata says captured at 960 fps (com.android.capture.fps), but 30 "
                   "fps is used as given"]
    assert main(["info", str(tmp_path / "a" / "tagged.h5")]) == 0
    assert ("captured at 960 fps (capture-rate metadata (com.android.capture.fps)), resize pad, conditioning "
            "temporal") in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.skipif(not (ROAD / "images").is_dir(), reason="shared DAVIS346 recording absent")
def test_read_noise_of_real_davis346_frames_does_not_become_events_on_dark_static_pixels(tmp_path):
    """The 59 APS frames of davis346_road through an ideal (noise-free) DVS: every event on a dark static pixel
    (< 20 DN throughout, range <= 10 DN) comes from the frames' read noise (1.4 DN rms there)."""
    ts = tmp_path / "ts.txt"
    ts.write_text("\n".join(line.split()[0] for line in (ROAD / "images.txt").read_text().splitlines()) + "\n")
    frames = np.stack([cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in sorted((ROAD / "images").glob("*.png"))])
    dark = (frames.max(0) < 20) & (frames.max(0).astype(int) - frames.min(0) <= 10)
    rates = {}
    for name, cond in (("raw", "off"), ("cond", {"noise_dn": 1.6})):
        convert(ROAD / "images", tmp_path / name, timestamps=ts, upsample="linear", progress=False,
                settings={"sensor": "ideal"}, conditioning=cond)
        ev = load(tmp_path / name / "images.h5").events
        on = (ev["p"] > 0) & dark[ev["y"], ev["x"]]
        rates[name] = on.sum() / dark.sum() / (ev["t"].max() / 1e6)
    assert rates["raw"] > 5.0  # Hz per pixel: read noise fires the ideal DVS
    assert rates["cond"] < 0.02 * rates["raw"]


def test_toml_scene_keys_are_the_flags(slow_clip, tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(f"""
[[sequence]]
name = "slow"
height = 40
width = 40
[sequence.scene]
type = "video"
path = "{slow_clip}"
slowmo = 32
upsample = "none"
resize = "pad"
conditioning = {{ noise_dn = 2.0, threshold_sigmas = 4.0 }}
""")
    spec = load_config(path).sequences[0]
    scene = build_scene(spec.scene, 40, 40, spec.duration_us)
    meta = scene.describe()
    assert meta["capture_fps"] == pytest.approx(960) and meta["resize"]["policy"] == "pad"
    assert meta["conditioning"]["noise_dn"] == 2.0 and meta["conditioning"]["key_frames"] is True
    path.write_text(path.read_text().replace("noise_dn", "noise"))
    with pytest.raises(EvsimInputError, match="unknown conditioning key 'noise'"):
        build_scene(load_config(path).sequences[0].scene, 40, 40, spec.duration_us)
